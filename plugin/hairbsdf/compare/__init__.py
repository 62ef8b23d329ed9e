"""hairbsdf.compare: render scenes with Cycles and with the hairbsdf engine, compare them with
noise-aware statistics and write a report (docs/compare.md).

    python -m hairbsdf.compare --scene swatch          # or the console script: hairbsdf compare
    from hairbsdf.compare import metrics               # the metrics alone, on NumPy arrays
"""

__all__ = ["main"]


def main(argv=None):
    from .cli import main as _main
    return _main(argv)
