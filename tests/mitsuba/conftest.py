"""Mitsuba's LLVM variants need libLLVM >= 16 (Debian 12's libLLVM 15 crashes Dr.Jit): point
Dr.Jit at libLLVM 19 when it is installed (run.sh installs it) and nothing else is set."""

from torchirid.mitsuba.scenes import find_libllvm

find_libllvm()
