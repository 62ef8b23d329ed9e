(function () {
  "use strict";
  // Hover swap: the Cycles image shows hairbsdf while the pointer is over it.
  document.querySelectorAll("img.swap").forEach(function (img) {
    var a = img.getAttribute("src"), b = img.getAttribute("data-swap");
    var cap = document.getElementById(img.getAttribute("data-caption"));
    var capA = cap ? cap.textContent : "", capB = img.getAttribute("data-swap-label") || "";
    img.addEventListener("mouseenter", function () { img.src = b; if (cap) { cap.textContent = capB; } });
    img.addEventListener("mouseleave", function () { img.src = a; if (cap) { cap.textContent = capA; } });
  });
  var filter = document.getElementById("filter");
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
