"""Differentiable material point method: materials, boundaries, kernels and rollouts."""

from rheo.physics.boundaries import Box, Collider, Cup, Floor, dam_break_gate, lifted_cup
from rheo.physics.materials import (
    HerschelBulkley,
    Material,
    MaterialError,
    NeoHookean,
    NewtonianFluid,
    Plasticine,
    make_material,
)
from rheo.physics.optional import OptionalPhysics
from rheo.physics.simulator import SimulationError, SimulationUnstable, Simulator, Trajectory

__all__ = [
    "Box", "Collider", "Cup", "Floor", "HerschelBulkley", "Material", "MaterialError", "NeoHookean",
    "NewtonianFluid", "OptionalPhysics", "Plasticine", "SimulationError", "SimulationUnstable", "Simulator",
    "Trajectory", "dam_break_gate", "lifted_cup", "make_material",
]
