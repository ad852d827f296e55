"""bridgefem: limit loads of masonry arch bridges (elastic voussoirs, unilateral frictional joints)."""
from importlib import metadata

PETSC_PREFIX = "bridgefem_"
"""Options prefix of the contact solver's PETSc objects: ``-bridgefem_ksp_type ...`` on the command line."""


def version() -> str:
    """The installed bridgefem version, or "source tree" when it runs from an uninstalled checkout."""
    try:
        return metadata.version("bridgefem")
    except metadata.PackageNotFoundError:
        return "source tree"
