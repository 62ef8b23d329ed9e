"""The native module and what it needs: the wheel is built for Linux x86-64 with glibc >= 2.34
(manylinux_2_34; its Embree and TBB come from a glibc 2.36 system)."""

import os
import platform

GLIBC_MIN = (2, 34)
REQUIREMENT = "Linux x86-64 with glibc >= %d.%d" % GLIBC_MIN


def glibc_version():
    """(major, minor) of the running glibc, or None on another C library."""
    try:
        name, _, ver = os.confstr("CS_GNU_LIBC_VERSION").partition(" ")  # "glibc 2.36"
    except (AttributeError, ValueError, OSError, TypeError):
        return None
    if name != "glibc":
        return None
    try:
        return tuple(int(x) for x in ver.split(".")[:2])
    except ValueError:
        return None


def _system():
    g = glibc_version()
    return "%s %s, %s" % (platform.system(), platform.machine(), "glibc %d.%d" % g if g else "no glibc")


def load_core():
    """hairbsdf._core, or ImportError naming the requirement."""
    g = glibc_version()
    if g is not None and g < GLIBC_MIN:
        raise ImportError("hairbsdf needs %s; this system has %s (build from source: README, Install)"
                          % (REQUIREMENT, _system()))
    try:
        from . import _core
    except ImportError as exc:
        raise ImportError("hairbsdf's native module did not load (%s). The wheel needs %s; this system is %s "
                          "(build from source: README, Install)" % (exc, REQUIREMENT, _system())) from exc
    return _core
