"""`SimCell` satisfies the `Cell` protocol the loop drives, and `StereoFrame` the `StereoCapture`.

Every member the protocols name exists on the simulated implementation with the same
parameters, and behaves as the protocol's docstrings say (time advances by `dt` per step,
a capture is stamped with its exposure and arrives no earlier).
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from robot_app.control import Cell, StereoCapture
from robot_app.sim import SimCell, World, WorldConfig

WORLD = WorldConfig.model_validate({"realism": "realistic", "cameras": {"image_size": [64, 48]}})


def protocol_members(protocol: type) -> dict[str, object]:
    return {
        name: member
        for name, member in vars(protocol).items()
        if not name.startswith("_") and (callable(member) or isinstance(member, property))
    } | {name: None for name in getattr(protocol, "__annotations__", {})}


def parameters(function: object) -> list[tuple[str, object]]:
    signature = inspect.signature(function)  # type: ignore[arg-type]
    return [(p.name, p.kind) for p in signature.parameters.values() if p.name != "self"]


def check_members(protocol: type, instance: object) -> None:
    members = protocol_members(protocol)
    assert members, f"{protocol.__name__} names no members"
    kind = type(instance).__name__
    for name, member in members.items():
        assert hasattr(instance, name), f"{kind} lacks {name}"
        if isinstance(member, property) or member is None:
            continue
        implemented = getattr(type(instance), name, None)
        assert callable(implemented), f"{kind}.{name} is not a method"
        assert parameters(implemented) == parameters(member), f"{kind}.{name} has other parameters"


def test_every_protocol_member_is_implemented_with_its_parameters() -> None:
    with World(WORLD) as world:
        cell = SimCell(world)
        check_members(Cell, cell)
        check_members(StereoCapture, cell.capture())


def test_the_simulated_cell_behaves_as_the_protocol_says() -> None:
    with World(WORLD) as world:
        cell: Cell = SimCell(world)  # the static check: mypy sees SimCell as a Cell here
        start = cell.time
        cell.command_joints(cell.joint_positions(), np.zeros(7))
        cell.step()
        assert cell.time == pytest.approx(start + cell.dt)
        q = cell.joint_positions()
        assert q.shape == (7,) and np.all(np.isfinite(q))
        capture: StereoCapture = cell.capture()
        assert capture.time == pytest.approx(cell.time)
        assert capture.available_time >= capture.time  # the camera's latency
        assert capture.left_bgr.dtype == np.uint8 and capture.right_bgr.shape == (48, 64, 3)
        assert capture.transform_right_camera_to_world.shape == (4, 4)
        assert isinstance(capture.dropped, bool)
        assert cell.grasp() == 0 and not cell.holding()  # nothing between the fingers
        assert cell.collisions() == 0
