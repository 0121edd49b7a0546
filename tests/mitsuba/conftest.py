"""Mitsuba's LLVM variants need libLLVM >= 16 (Debian 12's libLLVM 15 crashes Dr.Jit): point
Dr.Jit at libLLVM 19 when it is installed (run.sh installs it) and nothing else is set."""

import glob
import os

if "DRJIT_LIBLLVM_PATH" not in os.environ:
    for _path in sorted(glob.glob("/usr/lib/*/libLLVM-19.so*") + glob.glob("/usr/lib/*/libLLVM.so.19*")):
        os.environ["DRJIT_LIBLLVM_PATH"] = _path
        break
