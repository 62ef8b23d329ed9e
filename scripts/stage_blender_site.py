"""Copies the built hairbsdf package into build/blender_site/<hash>/ and points
build/blender_site/current at it atomically, so Blender processes that are already
running keep a consistent copy while a new one is staged (docs/blender.md)."""

import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

import hairbsdf._core as core

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "plugin" / "hairbsdf"
SITE = ROOT / "build" / "blender_site"


def package_files():
    """The package's Python files from the source tree, plus every built extension module
    (hairbsdf._core, hairbsdf._render, ...) from where pip installed them."""
    files = sorted(p for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                   and p.suffix not in (".so", ".pyc"))
    extensions = sorted(Path(core.__file__).parent.glob("_*.so"))
    return files + extensions


def main() -> int:
    files = package_files()
    digest = hashlib.sha1()
    for f in files:
        digest.update(str(f.name).encode())
        digest.update(f.read_bytes())
    tag = digest.hexdigest()[:16]
    target = SITE / tag
    if not target.exists():
        SITE.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=SITE, prefix=".staging-"))
        for f in files:
            rel = f.relative_to(PACKAGE) if f.is_relative_to(PACKAGE) else Path(f.name)
            dest = tmp / "hairbsdf" / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, dest)
        os.rename(tmp, target)
    link = SITE / "current"
    tmp_link = SITE / f".current-{os.getpid()}"
    if tmp_link.is_symlink():
        tmp_link.unlink()
    tmp_link.symlink_to(tag)
    os.replace(tmp_link, link)
    # Keep the newest few copies; running Blenders may still use an older one.
    copies = sorted((p for p in SITE.iterdir() if p.is_dir() and not p.name.startswith(".") and p.name != "current"),
                    key=lambda p: p.stat().st_mtime)
    for old in copies[:-3]:
        if old.name != tag:
            shutil.rmtree(old, ignore_errors=True)
    print(f"[setup] Blender copy: {link} -> {tag}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
