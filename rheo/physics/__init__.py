"""Differentiable material point method: materials, boundaries, kernels and rollouts. The names below load their
module (and torch and Warp with it) when first used, so that ``rheo.physics.device`` loads alone."""

from importlib import import_module

_MODULES = {
    "rheo.physics.boundaries": ("Box", "Collider", "Cup", "Floor", "dam_break_gate", "lifted_cup"),
    "rheo.physics.materials": ("HerschelBulkley", "Material", "MaterialError", "NeoHookean", "NewtonianFluid",
                               "Plasticine", "make_material"),
    "rheo.physics.optional": ("OptionalPhysics",),
    "rheo.physics.device": ("SimulationError",),
    "rheo.physics.simulator": ("SimulationUnstable", "Simulator", "Trajectory"),
}
_HOME = {name: module for module, names in _MODULES.items() for name in names}
__all__ = sorted(_HOME)


def __getattr__(name: str):
    if name not in _HOME:
        raise AttributeError(f"module 'rheo.physics' has no attribute {name!r}")
    return getattr(import_module(_HOME[name]), name)
