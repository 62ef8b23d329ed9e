# Sourced by scripts/setup and scripts/test: how every build of the C++ is compiled.
# ccache lets the module builds (Python 3.11 and 3.13) and the Release gtest build share the core's
# objects; it needs one compiler name in all of them (g++, what scikit-build-core picks).
if command -v ccache >/dev/null 2>&1; then
  export CMAKE_CXX_COMPILER_LAUNCHER=${CMAKE_CXX_COMPILER_LAUNCHER:-ccache}
fi
export CXX=${CXX:-g++}
