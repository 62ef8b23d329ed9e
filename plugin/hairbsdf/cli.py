"""The `hairbsdf` command: argparse subcommands, each with its own options (`hairbsdf COMMAND --help`).

    hairbsdf compare [options]         render with Cycles and hairbsdf, compare, write a report
    hairbsdf judge REF TEST [--out DIR]        judge any renderer's EXRs against reference EXRs
                                               (no Blender; docs/compare.md)
    hairbsdf report merge DIR... [--out DIR]   join shard reports
    hairbsdf scenes list|export|render         the scene library for any renderer: USD, MaterialX,
                                               settings, Cycles references (docs/portable_scenes.md)
    hairbsdf fit --target SPEC --model NAME [options]
                                       fit a model's parameters to a target BSDF (docs/fit.md)
    hairbsdf plot SPEC [--out DIR]     per-lobe polar plots, heat maps and albedo as PNGs
    hairbsdf --version                 the installed version

SPEC is one constructor call with literal keywords, e.g. "principled_hair(melanin=0.6)".
"""

import argparse
import sys

USAGE = __doc__.strip() + "\n\nRun `hairbsdf COMMAND --help` (compare, judge, scenes, fit, plot) for the options.\n"
COMMANDS = {
    "compare": "render with Cycles and hairbsdf, compare, write a report",
    "judge": "judge any renderer's EXRs against reference EXRs (no Blender)",
    "report": "report merge DIR... [--out DIR]: join shard reports",
    "scenes": "list, export (USD, MaterialX, Cycles references) or render the scene library",
    "fit": "fit a model's parameters to a target BSDF",
    "plot": "per-lobe polar plots, heat maps and albedo as PNGs",
}


def build_parser():
    from ._version import __version__
    p = argparse.ArgumentParser(
        prog="hairbsdf", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Hair BSDFs matching Blender Cycles, and the tools to prove it.",
        epilog="commands:\n" + __doc__.split("\n", 2)[2].rstrip()
        + "\n\nRun `hairbsdf COMMAND --help` for a command's options.")
    p.add_argument("--version", action="version", version="hairbsdf %s" % __version__)
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for name, text in COMMANDS.items():
        sub.add_parser(name, help=text, add_help=False)  # the command's own parser reads the rest
    return p


def main(argv=None):
    from ._deps import MissingDependency
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        return _dispatch(argv)
    except MissingDependency as exc:
        sys.stderr.write("hairbsdf: error: %s\n" % exc)
        return 1


def _dispatch(argv):
    parser = build_parser()
    # top-level options up to the command; everything after it belongs to the command's own parser
    i = next((k for k, a in enumerate(argv) if not a.startswith("-")), len(argv))
    try:
        args = parser.parse_args(argv[:i + 1])
    except SystemExit as exc:  # 0 after --help/--version, 2 for a usage error
        return exc.code if isinstance(exc.code, int) else 2
    rest = argv[i + 1:]
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    if args.command == "compare":
        from .compare.cli import main as compare_main
        return compare_main(rest, prog="hairbsdf compare")
    if args.command == "judge":
        from .compare.judge_cli import main as judge_main
        return judge_main(rest, prog="hairbsdf judge")
    if args.command == "scenes":
        from .compare.portable import main as scenes_main
        return scenes_main(rest, prog="hairbsdf scenes")
    if args.command == "fit":
        from .fit import main as fit_main
        return fit_main(rest, prog="hairbsdf fit")
    if args.command == "plot":
        from .plot import main as plot_main
        return plot_main(rest, prog="hairbsdf plot")
    if rest[:1] == ["merge"]:
        from .compare.cli import run_merge
        return run_merge(rest[1:])
    sys.stderr.write("usage: hairbsdf report merge DIR... [--out DIR]\n")
    return 2


if __name__ == "__main__":
    sys.exit(main())
