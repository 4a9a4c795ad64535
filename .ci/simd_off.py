"""Print the names of numpy's widest SIMD code paths this machine has, for
NPY_DISABLE_CPU_FEATURES (comma-separated): its AVX-512 targets when it has any (X86_V4,
AVX512_ICL, AVX512_SPR in numpy 2.4), else its AVX2/FMA3 one (X86_V3). With --check: exit
1 unless every name given in NPY_DISABLE_CPU_FEATURES is off in this process (numpy
ignores a name it does not know without a word, which would make the second pass a
copy of the first).

CI (.ci/run) runs the committed-output tests a second time without these paths: numpy's
AVX-512 sin, cos and exp differ from its AVX2 ones in the last bit, and a generated file
that depends on the last bit then changes from machine to machine (issue 34); the second
pass fails on the machine that makes such a file instead of on the next one."""

from __future__ import annotations

import os
import sys

from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

AVX512 = ("X86_V4", "AVX512")
AVX2 = ("X86_V3", "AVX2", "FMA3")


def widest() -> list[str]:
    have = [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]
    wide = [f for f in have if f.startswith(AVX512)]
    return wide or [f for f in have if f.startswith(AVX2)]


if __name__ == "__main__":
    if sys.argv[1:] == ["--check"]:
        named = [f for f in os.environ.get("NPY_DISABLE_CPU_FEATURES", "").split(",") if f]
        on = [f for f in named if __cpu_features__.get(f)]
        if not named or on:
            sys.exit(f"NPY_DISABLE_CPU_FEATURES={','.join(named)!r}: still on: {on or 'nothing named'}")
    else:
        print(",".join(widest()))
