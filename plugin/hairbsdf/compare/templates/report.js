(function () {
  "use strict";
  function $(id) { return document.getElementById(id); }
  // Wipe: ours (img.top) covers the reference from the slider's position to the right.
  function wipe(top, percent) { top.style.clipPath = "inset(0 0 0 " + percent + "%)"; }
  document.querySelectorAll("figure.pair").forEach(function (f) {
    var top = f.querySelector("img.top"), range = f.querySelector("input.wipe-range");
    range.addEventListener("input", function () { wipe(top, range.value); });
    wipe(top, range.value);
  });

  // Viewer: a click opens the image full size; both layers share one transform, so zoom and pan
  // stay linked while the wipe swaps the reference and ours.
  var viewer = $("viewer"), pan = $("v-pan"), a = $("v-a"), b = $("v-b"), range = $("v-wipe");
  var zoom = 1, x = 0, y = 0, drag = null;
  function apply() {
    pan.style.transform = "translate(" + x + "px," + y + "px) scale(" + zoom + ")";
    $("v-zoom").textContent = Math.round(zoom * 100) + "%";
  }
  function setZoom(z) { zoom = Math.min(128, Math.max(0.25, z)); apply(); }
  function fit() {  // full size, enlarged by a whole factor while the image fits the window
    var st = $("v-stage");
    var k = Math.floor(Math.min(st.clientWidth / a.naturalWidth, st.clientHeight / a.naturalHeight));
    x = 0; y = 0; setZoom(Math.max(1, k || 1));
  }
  function open(img) {
    var other = img.getAttribute("data-b");
    a.onload = fit;
    a.src = img.getAttribute("src");
    b.hidden = !other; $("v-wipe-label").hidden = !other;
    if (other) { b.src = other; wipe(b, range.value); }
    $("v-title").textContent = img.getAttribute("data-title") || "";
    viewer.hidden = false;
    if (a.complete && a.naturalWidth) { fit(); }
  }
  function close() { viewer.hidden = true; }
  document.querySelectorAll("img.view").forEach(function (img) {
    img.addEventListener("click", function () { open(img); });
  });
  range.addEventListener("input", function () { wipe(b, range.value); });
  $("v-in").addEventListener("click", function () { setZoom(zoom * 2); });
  $("v-out").addEventListener("click", function () { setZoom(zoom / 2); });
  $("v-one").addEventListener("click", function () { x = 0; y = 0; setZoom(1); });
  $("v-close").addEventListener("click", close);
  document.addEventListener("keydown", function (e) { if (e.key === "Escape") { close(); } });
  var stage = $("v-stage");
  stage.addEventListener("wheel", function (e) {
    e.preventDefault(); setZoom(zoom * (e.deltaY < 0 ? 1.25 : 0.8));
  }, { passive: false });
  stage.addEventListener("mousedown", function (e) { e.preventDefault(); drag = [e.clientX - x, e.clientY - y]; });
  window.addEventListener("mousemove", function (e) {
    if (drag) { x = e.clientX - drag[0]; y = e.clientY - drag[1]; apply(); }
  });
  window.addEventListener("mouseup", function () { drag = null; });

  // Copy buttons of the reproduce lines (the text is selected where the clipboard is refused).
  document.querySelectorAll(".repro button.copy").forEach(function (btn) {
    var code = btn.parentNode.querySelector("code");
    btn.addEventListener("click", function () {
      var sel = window.getSelection(), r = document.createRange();
      r.selectNodeContents(code); sel.removeAllRanges(); sel.addRange(r);
      if (navigator.clipboard) {
        navigator.clipboard.writeText(code.textContent).then(function () { btn.textContent = "copied"; },
                                                            function () { btn.textContent = "selected"; });
      }
    });
  });

  var filter = $("filter");
  if (filter) {
    filter.addEventListener("change", function () {
      document.querySelectorAll("section.case").forEach(function (s) {
        var st = s.getAttribute("data-status");
        var show = filter.value === "all" ||
          (filter.value === "bad" && ["FAIL", "CRASH", "NO OUTPUT", "ERROR"].indexOf(st) >= 0) ||
          (filter.value === "pending" && st === "PENDING");
        s.classList.toggle("hidden", !show);
      });
    });
  }
})();
