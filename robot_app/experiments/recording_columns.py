"""Rows of a recording buffered per entity and sent as columns (`send_columns`).

One `rr.log` call costs ~0.1-0.5 ms of the caller's time (more on a loaded core), far
more than the data it carries; an episode has thousands of rows. `TimedColumns` keeps
each entity's rows (cell time [s], vision cycle or none, value) and sends them with one
`send_columns` per entity and kind when flushed, which costs ~1 µs per row.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

Kind = Literal["pose", "scalar", "point", "image", "strips", "path", "mesh", "text"]


@dataclass
class _Rows:
    kind: Kind
    with_cycles: bool
    times: list[float] = field(default_factory=list)
    cycles: list[int] = field(default_factory=list)
    values: list[Any] = field(default_factory=list)


class TimedColumns:
    """Rows waiting to be sent, per entity path.

    Args:
        rr: the imported `rerun` module.
        recording: the `rerun.RecordingStream` to send to.
    """

    def __init__(self, rr: ModuleType, recording: Any) -> None:
        self.rr, self._rec = rr, recording
        self._rows: dict[str, _Rows] = {}
        self.pending = 0

    def add(self, entity: str, kind: Kind, time: float, value: Any, cycle: int | None = None) -> None:
        """Buffers one row of `entity`.

        Args:
            entity: entity path; one kind per entity.
            kind: "pose" (4x4 [m]), "scalar", "point" ((3,) [m]), "image" (JPEG bytes),
                "strips" (list of (K, 2) polylines [px]), "path" ((K, 3) polyline [m]),
                "mesh" ((N, 3) vertices [m]),
                "text" ((text, level)).
            time: cell time [s].
            value: the row's value, as `kind` says.
            cycle: the vision cycle, for rows on both timelines (all rows of an entity
                have one, or none has).
        """
        rows = self._rows.setdefault(entity, _Rows(kind, cycle is not None))
        if rows.kind != kind or rows.with_cycles != (cycle is not None):  # a bug of ours
            raise ValueError(
                f"entity {entity!r}: rows of one kind ({rows.kind}), all with a vision cycle or none"
            )
        rows.times.append(float(time))
        if cycle is not None:
            rows.cycles.append(int(cycle))
        rows.values.append(value)
        self.pending += 1

    def flush(self) -> None:
        """Sends every buffered row (one `send_columns` per entity) and empties the buffer."""
        for entity, rows in self._rows.items():
            if rows.values:
                self._send(entity, rows)
                rows.times.clear()
                rows.cycles.clear()
                rows.values.clear()
        self.pending = 0

    def send_series(self, entity: str, times: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Sends scalar time series on `cell_time` right away (arrays, no per-row work).

        Args:
            entity: entity path.
            times: (T,) cell times [s].
            values: (T,) one series, or (T, S) S series (one plot line each).
        """
        rr = self.rr
        index = [rr.TimeColumn("cell_time", duration=np.asarray(times, dtype=float))]
        array = np.asarray(values, dtype=float)
        columns = rr.Scalars.columns(scalars=array.reshape(-1))
        if array.ndim == 2:
            columns = columns.partition([array.shape[1]] * array.shape[0])
        self._rec.send_columns(entity, indexes=index, columns=columns)

    def _send(self, entity: str, rows: _Rows) -> None:
        rr = self.rr
        index = [rr.TimeColumn("cell_time", duration=np.asarray(rows.times))]
        if rows.with_cycles:
            index.append(rr.TimeColumn("vision_cycle", sequence=np.asarray(rows.cycles)))
        values = rows.values
        if rows.kind == "pose":
            poses = np.asarray(values, dtype=float)
            columns = rr.Transform3D.columns(translation=poses[:, :3, 3], mat3x3=poses[:, :3, :3])
        elif rows.kind == "scalar":
            columns = rr.Scalars.columns(scalars=np.asarray(values, dtype=float))
        elif rows.kind == "point":
            columns = rr.Points3D.columns(positions=np.asarray(values, dtype=float).reshape(-1, 3))
        elif rows.kind == "image":
            columns = rr.EncodedImage.columns(blob=values, media_type=["image/jpeg"] * len(values))
        elif rows.kind == "strips":
            strips = [strip for row in values for strip in row]
            columns = rr.LineStrips2D.columns(strips=strips).partition([len(row) for row in values])
        elif rows.kind == "path":
            columns = rr.LineStrips3D.columns(strips=values)
        elif rows.kind == "mesh":
            vertices = np.concatenate(values).astype(np.float32)
            columns = rr.Mesh3D.columns(vertex_positions=vertices).partition([len(v) for v in values])
        else:
            columns = rr.TextLog.columns(text=[t for t, _ in values], level=[level for _, level in values])
        self._rec.send_columns(entity, indexes=index, columns=columns)


__all__ = ["Kind", "TimedColumns"]
