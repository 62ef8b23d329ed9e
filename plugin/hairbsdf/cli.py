"""The `hairbsdf` command.

    hairbsdf compare [options]         render with Cycles and hairbsdf, compare, write a report
    hairbsdf judge REF TEST [--out DIR]        judge any renderer's EXRs against reference EXRs
                                               (no Blender; docs/compare.md)
    hairbsdf report merge DIR... [--out DIR]   join shard reports
    hairbsdf fit --target SPEC --model NAME [options]
                                       fit a model's parameters to a target BSDF (docs/fit.md)
    hairbsdf plot SPEC [--out DIR]     per-lobe polar plots, heat maps and albedo as PNGs
    hairbsdf --version                 the installed version

SPEC is one constructor call with literal keywords, e.g. "principled_hair(melanin=0.6)".
"""

import sys

USAGE = __doc__.strip() + "\n\nRun `hairbsdf COMMAND --help` (compare, judge, fit, plot) for the options.\n"


def main(argv=None):
    from ._deps import MissingDependency
    try:
        return _dispatch(list(sys.argv[1:] if argv is None else argv))
    except MissingDependency as exc:
        sys.stderr.write("hairbsdf: error: %s\n" % exc)
        return 1


def _dispatch(argv):
    if not argv or argv[0] in ("-h", "--help", "help"):
        sys.stdout.write(USAGE)
        return 0 if argv else 2
    if argv[0] == "--version":
        from ._version import __version__
        print("hairbsdf %s" % __version__)
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd == "compare":
        from .compare.cli import main as compare_main
        return compare_main(rest, prog="hairbsdf compare")
    if cmd == "judge":
        from .compare.judge_cli import main as judge_main
        return judge_main(rest, prog="hairbsdf judge")
    if cmd == "fit":
        from .fit import main as fit_main
        return fit_main(rest, prog="hairbsdf fit")
    if cmd == "plot":
        from .plot import main as plot_main
        return plot_main(rest, prog="hairbsdf plot")
    if cmd == "report":
        if rest[:1] == ["merge"]:
            from .compare.cli import run_merge
            return run_merge(rest[1:])
        sys.stderr.write("usage: hairbsdf report merge DIR... [--out DIR]\n")
        return 2
    sys.stderr.write("hairbsdf: unknown command '%s'\n\n%s" % (cmd, USAGE))
    return 2


if __name__ == "__main__":
    sys.exit(main())
