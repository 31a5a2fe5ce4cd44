"""Is the J-A kernel vectorised? Counts in numba's own assembly of its integration loop (issue 15).

    python bench/kernel_asm.py

numba will not show the assembly of code it loaded from its cache, so this compiles the kernel afresh into a
temporary cache folder (~7 s). Printed: the double-precision arithmetic instructions that work on packed
vectors (...pd) against scalar ones (...sd), the vector registers used (zmm: 8 doubles, ymm: 4, xmm: 2 or a
scalar), and the calls by name (no libm exp or log expected: they are inlined arithmetic, anhysteretic.py;
indirect calls through a register are counted apart).
"""

import os
import re
import sys
import tempfile
from collections import Counter

ARITH = r"v?(?:fmadd|fmsub|fnmadd|fnmsub|add|sub|mul|div|max|min|sqrt)\d*"


def counts(asm: str) -> dict:
    ops = Counter(re.findall(r"^\s+([a-z][a-z0-9]*)\s", asm, flags=re.M))
    return {"packed": sum(n for op, n in ops.items() if re.fullmatch(ARITH + "pd", op)),
            "scalar": sum(n for op, n in ops.items() if re.fullmatch(ARITH + "sd", op)),
            "zmm": len(re.findall(r"%zmm\d", asm)), "ymm": len(re.findall(r"%ymm\d", asm)),
            "xmm": len(re.findall(r"%xmm\d", asm)),
            "calls": sorted(set(re.findall(r"^\s+call[a-z]*\s+([^*\s]\S*)", asm, flags=re.M))),
            "indirect": len(re.findall(r"^\s+call[a-z]*\s+\*", asm, flags=re.M))}


def function_body(asm: str, name: str) -> str:
    """The assembly of the one function whose symbol contains ``name`` (up to the next function's label)."""
    parts = re.split(r"^([_A-Za-z][^\s:]*):$", asm, flags=re.M)  # [head, label, body, label, body, ...]
    bodies = [body for label, body in zip(parts[1::2], parts[2::2]) if name in label]
    return bodies[0] if bodies else ""


def main() -> None:
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="mrhyst_asm_")  # before numba is imported
    os.environ["MRHYST_AOT"] = "0"  # the JIT kernel (mrhyst.model.aot), whose assembly numba shows
    import numpy as np
    from mrhyst.model import ja

    H = np.concatenate([np.linspace(0.0, 6000.0, 27), np.linspace(6000.0, 0.0, 27)[1:]])
    ja.simulate_h(np.array([1.2e6, 2000.0, 1e-3, 0.2, 1500.0]), H, form="physical", substeps=2)
    disp = ja._simulate_batch
    asm = disp.inspect_asm(disp.signatures[0])
    block = function_body(asm, "6ja_jit6_block")  # the integration loop; the rest is set-up and the CPython wrapper
    c = counts(block)
    import llvmlite.binding as llvm

    print(f"cpu {llvm.get_host_cpu_name()}: ja_jit._simulate_batch compiles to {len(asm.splitlines())} lines of "
          "assembly, "
          f"{len(block.splitlines())} of them the integration loop (ja_jit._block), counted here")
    print(f"double arithmetic: {c['packed']} packed (...pd), {c['scalar']} scalar (...sd)")
    print(f"register operands: zmm {c['zmm']}, ymm {c['ymm']}, xmm {c['xmm']}")
    print(f"calls by name: {', '.join(c['calls']) or 'none'}; indirect calls: {c['indirect']}")
    sys.exit(0)


if __name__ == "__main__":
    main()
