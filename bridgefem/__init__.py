"""bridgefem: limit loads of masonry arch bridges (elastic voussoirs, unilateral frictional joints).

The public API is :mod:`bridgefem.api`, loaded on first use of one of its names so that ``import bridgefem`` stays
cheap (DOLFINx and PETSc load when :func:`bridgefem.analyse` runs)::

    import bridgefem

    scene = bridgefem.load_scene("demos/bare_arch.toml")
    result = bridgefem.analyse(scene)        # result.status, result.limit_load.lower / .upper (N), result.lp, ...
"""

__all__ = ["LimitLoad", "Result", "RigidBlock", "Scene", "SceneError", "Status", "analyse", "assess_vehicle",
           "edit", "load_scene", "lp", "scene_from_dict"]


def __getattr__(name: str):
    if name in __all__:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'bridgefem' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
