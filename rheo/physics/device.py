"""Where simulations run, chosen without loading the simulator (a stage that simulates nothing starts without torch
or Warp), and the error of a rollout that cannot be run as asked."""

from __future__ import annotations

DEVICES = ("auto", "cpu", "cuda")
_default_device = "cpu"


class SimulationError(RuntimeError):
    """A rollout that cannot be run as asked."""


def _checked_device(name: str) -> str:
    if name not in DEVICES:
        raise SimulationError(f"simulation device {name!r} must be one of {', '.join(DEVICES)}")
    return name


def set_default_device(name: str) -> None:
    """The device of simulators built without one: "cpu", "cuda" (the first GPU) or "auto" (CUDA when Warp sees a
    GPU, else the CPU); resolved when a simulator is built."""
    global _default_device
    _default_device = _checked_device(name)


def resolve_device(name: str | None = None) -> str:
    """Warp's name of the device ``name`` (the default device if None) stands for: "cpu" or "cuda:0"."""
    import warp as wp  # only where a device is resolved: a simulation, a benchmark's record

    name = _checked_device(_default_device if name is None else name)
    wp.init()
    gpus = wp.get_cuda_device_count()
    if name == "cuda" and gpus == 0:
        raise SimulationError("simulation.device is cuda, but Warp sees no CUDA GPU on this machine (set it to auto "
                              "or cpu)")
    return "cuda:0" if name == "cuda" or (name == "auto" and gpus > 0) else "cpu"


def device_name(name: str | None = None) -> str:
    """The device ``name`` resolves to, for a benchmark's record: "cpu", or "cuda:0 (<GPU model>)"."""
    import warp as wp

    resolved = resolve_device(name)
    return resolved if resolved == "cpu" else f"{resolved} ({wp.get_device(resolved).name})"
