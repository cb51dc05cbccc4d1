"""Reading a foam-mj Rerun recording (``.rrd``) back, with Rerun's own ``RrdReader``: the rows per entity, a
component's values, and the views of the stored blueprint (tests, inspection; re-exported by
:mod:`foam_mj.recording`)."""

from __future__ import annotations

from pathlib import Path

from rerun.chunk import RrdReader


def _store_chunks(path: str | Path, blueprint: bool = False):
    reader = RrdReader(Path(path))
    if blueprint:
        stores = reader.blueprints()
        if not stores:
            return []
        return list(reader.stream(store=stores[0]))
    return list(reader.stream())


def read_recording(path: str | Path, static: bool | None = None) -> dict[str, int]:
    """Entity path (as logged, no leading '/') -> total rows over all chunks of the recording store of an
    ``.rrd`` file: all rows (``static=None``), only static ones (True) or only temporal ones (False).
    Internal entities (``__properties``) are left out. Raises on a file without its footer (not closed)."""
    RrdReader(Path(path)).store()  # raises on a file without footer/manifest
    rows: dict[str, int] = {}
    for ch in _store_chunks(path):
        entity = str(ch.entity_path).lstrip("/")
        if entity.startswith("__") or (static is not None and bool(ch.is_static) != static):
            continue
        rows[entity] = rows.get(entity, 0) + int(ch.num_rows)
    return rows


def read_component(path: str | Path, entity: str, component: str) -> list:
    """Every row's value of ``component`` (e.g. "Ellipsoids3D:centers") at ``entity``, in file order,
    as Python lists (pyarrow ``to_pylist``); rows where the component is absent are skipped."""
    out: list = []
    for ch in _store_chunks(path):
        if str(ch.entity_path).lstrip("/") != entity.lstrip("/"):
            continue
        batch = ch.to_record_batch()
        if component in batch.schema.names:
            out.extend(v for v in batch.column(component).to_pylist() if v is not None)
    return out


def read_blueprint(path: str | Path) -> list[dict[str, str | None]]:
    """The views of the blueprint stored in an ``.rrd`` file: [{"class": "3D", "origin": "world", "name": ...}]."""
    views: dict[str, dict[str, str | None]] = {}
    for ch in _store_chunks(path, blueprint=True):
        entity = str(ch.entity_path)
        batch = ch.to_record_batch()
        for column, key in (("ViewBlueprint:class_identifier", "class"), ("ViewBlueprint:space_origin", "origin"), ("ViewBlueprint:display_name", "name")):
            if column in batch.schema.names:
                for v in batch.column(column).to_pylist():
                    if v:
                        views.setdefault(entity, {"class": None, "origin": None, "name": None})[key] = v[0]
    return list(views.values())
