"""A small thread-safe progress bar on stderr (one line per step when not a terminal)."""

from __future__ import annotations

import sys
import threading
import time


class Progress:
    def __init__(self, total, stream=None, enabled=True, width=28):
        self.total = max(int(total), 0)
        self.done = 0
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.width = width
        self.t0 = time.time()
        self.lock = threading.Lock()
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def add(self, n):
        with self.lock:
            self.total += int(n)

    def step(self, label, ok=True):
        with self.lock:
            self.done += 1
            if not self.enabled:
                return
            el = time.time() - self.t0
            frac = self.done / self.total if self.total else 1.0
            eta = el / frac - el if frac > 0 else 0.0
            fill = int(round(frac * self.width))
            bar = "#" * fill + "." * (self.width - fill)
            mark = "" if ok else "  [!]"
            line = "[%s] %d/%d  %s  %s elapsed, ~%s left%s" % (bar, self.done, self.total, label, _fmt(el), _fmt(eta),
                                                            mark)
            if self.tty:
                self.stream.write("\r\033[K" + line[:200])
                if self.done >= self.total:
                    self.stream.write("\n")
            else:
                self.stream.write(line + "\n")
            self.stream.flush()

    def message(self, text):
        with self.lock:
            if not self.enabled:
                return
            if self.tty:
                self.stream.write("\r\033[K")
            self.stream.write(text + "\n")
            self.stream.flush()


def _fmt(s):
    s = int(round(s))
    return "%dm%02ds" % (s // 60, s % 60) if s >= 60 else "%ds" % s
