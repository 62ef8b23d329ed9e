"""pytest plugin (loaded by pytest.ini): under CI, a skipped or xfailed test fails the run unless
test_support/allowlist.toml names it ([[skip]]), with a reason.

A skip in CI almost always means a missing build or install step, which would otherwise pass
silently. Outside CI this plugin only lists the offenders.
"""

import fnmatch
import tomllib
from pathlib import Path

from ci import under_ci

ALLOWLIST = Path(__file__).with_name("allowlist.toml")


def load_allowlist(path=ALLOWLIST):
    """[(nodeid glob, kind, reason)] of the [[skip]] entries; each needs a kind ('skip' or 'xfail') and a reason."""
    entries = tomllib.loads(Path(path).read_text()).get("skip", [])
    out = []
    for k, e in enumerate(entries):
        nodeid, kind, reason = e.get("nodeid", ""), e.get("kind", ""), e.get("reason", "").strip()
        if not nodeid or kind not in ("skip", "xfail") or not reason:
            raise ValueError("%s: [[skip]] entry %d needs nodeid, kind ('skip' or 'xfail') and a reason" % (path, k + 1))
        out.append((nodeid, kind, reason))
    return out


def allowed(nodeid, kind, allowlist):
    return any(k == kind and fnmatch.fnmatchcase(nodeid, pattern) for pattern, k, _ in allowlist)


class _Collector:
    def __init__(self, config):
        self.config = config
        self.allowlist = load_allowlist(config.getini("skip_allowlist") or ALLOWLIST)
        self.offenders = []

    def _record(self, report):
        if not report.skipped:
            return
        kind = "xfail" if hasattr(report, "wasxfail") else "skip"
        if not allowed(report.nodeid, kind, self.allowlist):
            longrepr = report.longrepr
            reason = longrepr[2] if isinstance(longrepr, tuple) else getattr(report, "wasxfail", str(longrepr))
            self.offenders.append((kind, report.nodeid, reason))

    def pytest_runtest_logreport(self, report):
        self._record(report)

    def pytest_collectreport(self, report):
        self._record(report)

    def pytest_sessionfinish(self, session):
        if hasattr(self.config, "workerinput") or not self.offenders:
            return  # xdist workers: the controller sees every report
        tr = self.config.pluginmanager.get_plugin("terminalreporter")
        strict = under_ci()
        if tr is not None:
            tr.write_line("")
            tr.write_sep("=", "skips and xfails not in %s%s" % (
                ALLOWLIST.name, " (CI: these fail the run)" if strict else ""), red=strict, yellow=not strict)
            for kind, nodeid, reason in self.offenders:
                tr.write_line("%s %s: %s" % (kind.upper(), nodeid, reason))
        if strict and session.exitstatus == 0:
            session.exitstatus = 1


def pytest_addoption(parser):
    parser.addini("skip_allowlist", "TOML file of the skips and xfails allowed under CI", default="")


def pytest_configure(config):
    config.pluginmanager.register(_Collector(config), "hairbsdf_ci_gate")
