"""The environment ``./run`` installs, as the analyses load it."""
import ast
import os
import subprocess
import sys

PROBE = """
import bridgefem.fe.model  # numpy, PETSc (started without the folder's option files) and DOLFINx
maps = {line.split()[-1] for line in open('/proc/self/maps')}
print(sorted(m for m in maps if m.rsplit('/', 1)[-1].startswith(('libblas', 'liblapack', 'libopenblas'))))
"""


def test_the_blas_is_openblas():
    """numpy and PETSc (MUMPS inside it) load OpenBLAS's BLAS and LAPACK, which ``./run`` installs
    (``libopenblas0-serial``) and Debian's alternatives then choose over the reference (netlib) libraries."""
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True).stdout
    loaded = ast.literal_eval(out.strip().splitlines()[-1])
    assert loaded, "no BLAS mapped: the probe proves nothing"
    assert all("openblas" in path for path in loaded), loaded


KERNELS = """
import ctypes, numpy
library = next(m for m in {line.split()[-1] for line in open('/proc/self/maps')} if 'openblas' in m)
openblas = ctypes.CDLL(library)
openblas.openblas_get_corename.restype = ctypes.c_char_p
print(openblas.openblas_get_corename().decode())
"""


def test_openblas_runs_the_kernels_of_the_processors_instruction_sets():
    """Under ``./run`` (this suite's environment) OpenBLAS runs the kernels the processor's instruction sets allow,
    whatever model number it has: SkylakeX's with AVX-512, Haswell's with AVX2 and FMA (OpenBLAS 0.3.21 gives a model
    newer than it knows its SSE3 kernels, Prescott's, 5x slower), or those of your own OPENBLAS_CORETYPE, which
    ``./run`` keeps; the probe reads the kernels the library chose."""
    lines = [line for line in open("/proc/cpuinfo") if line.startswith("flags")]
    flags = set(lines[0].split(":", 1)[1].split()) if lines else set()
    expected = ("SkylakeX" if {"avx512f", "avx512bw", "avx512dq", "avx512vl", "avx512cd"} <= flags
                else "Haswell" if {"avx2", "fma"} <= flags else None)
    own = os.environ.get("OPENBLAS_CORETYPE")
    if own and expected and own.lower() != expected.lower():  # yours, set before ./run
        expected = own
    core = subprocess.run([sys.executable, "-c", KERNELS], capture_output=True, text=True, check=True).stdout.split()[-1]
    assert core.lower() == expected.lower() if expected else core, (core, expected)
