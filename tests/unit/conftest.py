"""Fixtures shared by the unit tests: one RigidWorld per test module, cleared per test (rigid-body
tests); one RenderScene per test module (render tests)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def world(taichi_runtime):
    from rigid.world import RigidWorld

    w = RigidWorld(capacity_bodies=16, capacity_spheres=512, capacity_colliders=4)
    yield w
    w.release()


@pytest.fixture
def fresh(world):
    from rigid.world import RigidConfig

    world.clear()
    world.config = RigidConfig()
    return world


@pytest.fixture(scope="module")
def scene(taichi_runtime):
    from render.scene_data import RenderScene

    s = RenderScene()
    yield s
    s.release()
