"""A scene as a document: edited in Python and re-validated, or resolved into plain data.

An edit works on the document the scene was validated from (:attr:`Scene.document`, the TOML file as given), not
on the resolved scene, so that it means what the same change in the file would mean:

1. each section given replaces the keys it names in that section of the document (a key set to None is removed,
   so that its default applies again); a section set to None is removed (e.g. ``fill=None``: a bare arch); the
   ``load`` section is the list of ``[[load]]`` tables and is replaced whole;
2. the changed document is validated by :func:`bridgefem.scene.reader.scene_from_dict` as a file would be: a bad
   value or an unknown key raises the same one-line :class:`~bridgefem.scene.keys.SceneError`, and whatever the
   schema derives (a semicircular ring's rise, a preset's mesh and tolerance, an elastic abutment's material) is
   derived again from the new values.

A scene changed outside the schema (``dataclasses.replace``) no longer matches its document; editing it raises
ValueError instead of silently undoing that change.
"""
from __future__ import annotations

import copy
import tomllib
from typing import Any

from .model import Scene
from .reader import resolved_toml, scene_from_dict
from .schema import SCHEMA


def edit(scene: Scene, /, **sections: dict[str, Any] | list[dict[str, Any]] | None) -> Scene:
    """The scene with the keys of ``sections`` changed, validated as a scene file would be, e.g.
    ``edit(scene, arch={"span": 12.0, "thickness": 0.8}, joints={"friction": 0.5})`` (the ``[scene]`` section too:
    ``edit(scene, scene={"name": "wider"})``)."""
    if scene.document is None or scene_from_dict(scene.document, scene.name) != scene:
        raise ValueError("this scene was not built by the schema, or was changed outside it (dataclasses.replace): "
                         "edit the scene it came from, or load it again")
    document = copy.deepcopy(scene.document)
    for name, values in sections.items():
        if values is None:
            document.pop(name, None)
        elif isinstance(values, dict) and name != "load":
            table = document.setdefault(name, {})
            for key, value in values.items():
                if value is None:
                    table.pop(key, None)
                else:
                    table[key] = copy.deepcopy(value)
        else:  # the [[load]] tables, or a value the schema refuses as a file's
            document[name] = copy.deepcopy(values)
    return scene_from_dict(document, scene.name)


def resolved_document(scene: Scene) -> dict[str, Any]:
    """The scene with every key resolved, as plain data (what ``bridgefem check`` prints as TOML, read back): a
    valid scene document itself."""
    return tomllib.loads(resolved_toml(scene))


def key_units() -> dict[str, dict[str, str]]:
    """The unit of every scene key that has one, by section (from :data:`bridgefem.scene.schema.SCHEMA`)."""
    return {section: {k: key.unit for k, key in keys.items() if key.unit} for section, keys in SCHEMA.items()}
