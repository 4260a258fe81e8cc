"""Shared fixtures: one finalized plant of the robot and pool."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.plant import add_plant


@pytest.fixture(scope="session")
def robot_plant():
    """(diagram, PlantHandles) of the free-floating robot in the pool."""
    builder = DiagramBuilder()
    handles = add_plant(builder)
    return builder.Build(), handles


@pytest.fixture
def rng():
    return np.random.default_rng(20260423)
