"""The environment ``./run`` installs, as the analyses load it."""
import ast
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
