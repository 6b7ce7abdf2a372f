"""Constitutive models the simulator knows, with their parameters, checks and stability scales.

All values are SI: stresses and moduli in Pa, consistency in Pa s^n, viscosity in Pa s, density in kg/m^3.
``tau_y`` is a shear yield stress: the material yields when the equivalent shear stress |s|/sqrt(2) (s the deviatoric
Kirchhoff stress) exceeds it, so that in simple shear the flow curve is tau = tau_y + K gamma_dot^n.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import torch

from rheo.physics import kernels as k


class MaterialError(ValueError):
    """A material name or parameter that the simulator cannot use."""


def _check(name: str, value: float, *, minimum: float = 0.0, strict: bool = True) -> None:
    ok = math.isfinite(value) and (value > minimum if strict else value >= minimum)
    if not ok:
        limit = f"> {minimum:g}" if strict else f">= {minimum:g}"
        raise MaterialError(f"material parameter {name} = {value!r} is invalid: it must be finite and {limit}")


@dataclass(frozen=True)
class Material:
    """Base class: a constitutive model with named, differentiable parameters."""

    model: ClassVar[int]
    density: float = 1000.0

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in fields(self))

    def parameters(self, dtype: torch.dtype = torch.float64) -> torch.Tensor:
        """The parameter values, in the order of ``parameter_names``."""
        return torch.tensor([getattr(self, n) for n in self.parameter_names], dtype=dtype)

    def kernel_vector(self, values: torch.Tensor) -> torch.Tensor:
        """Map parameter values (ordered as ``parameter_names``) to the kernels' layout, differentiably."""
        raise NotImplementedError

    def wave_speed(self) -> float:
        """The fastest elastic (or acoustic) wave speed, for the time-step limit."""
        raise NotImplementedError

    def diffusive_time_step(self, dx: float) -> float:
        """Stability limit of an explicit viscous term (infinite when viscosity is treated implicitly)."""
        return math.inf

    def __post_init__(self) -> None:
        _check("density", self.density)


def _layout(**entries: torch.Tensor) -> torch.Tensor:
    index = {"mu": k.P_MU, "lam": k.P_LAM, "tau_y": k.P_TAU_Y, "K": k.P_K, "n": k.P_N, "density": k.P_RHO}
    ref = next(iter(entries.values()))
    out = [torch.zeros((), dtype=ref.dtype)] * k.N_MATERIAL_PARAMS
    out[k.P_N] = torch.ones((), dtype=ref.dtype)
    for key, value in entries.items():
        out[index[key]] = value
    return torch.stack(out)


@dataclass(frozen=True)
class HerschelBulkley(Material):
    """Elasto-viscoplastic Herschel-Bulkley fluid on Hencky strain (Yue et al. 2015 return mapping).

    Below the yield stress it is a Hencky (StVK in log strain) solid with Lame constants mu and lam; above, the
    equivalent shear stress relaxes to tau_y + K gamma_dot^n. With n = 1 it is the Bingham model (plastic
    viscosity K) used by PAC-NeRF and the thesis.
    """

    model: ClassVar[int] = k.MODEL_HERSCHEL_BULKLEY
    tau_y: float = 100.0
    K: float = 10.0
    n: float = 1.0
    mu: float = 1.0e4
    lam: float = 1.0e4

    def __post_init__(self) -> None:
        super().__post_init__()
        _check("tau_y", self.tau_y, strict=False)
        _check("K", self.K)
        _check("n", self.n)
        _check("mu", self.mu)
        _check("bulk modulus lam + 2 mu / 3", self.lam + 2.0 * self.mu / 3.0)

    @classmethod
    def bingham(cls, tau_y: float, eta: float, mu: float, lam: float, density: float = 1000.0) -> HerschelBulkley:
        return cls(tau_y=tau_y, K=eta, n=1.0, mu=mu, lam=lam, density=density)

    @classmethod
    def from_pacnerf(cls, sigma_y: float, eta: float, mu: float, lam: float,
                     density: float = 1000.0) -> HerschelBulkley:
        """PAC-NeRF's (and the thesis') Bingham parameters: its code yields at |s| > sqrt(2/3) sigma_y and relaxes
        |s| by delta / (1 + eta / (2 mu dt)), the same law as tau_y = sigma_y / sqrt(3), K = eta / 2 here."""
        return cls.bingham(tau_y=sigma_y / math.sqrt(3.0), eta=eta / 2.0, mu=mu, lam=lam, density=density)

    def kernel_vector(self, values: torch.Tensor) -> torch.Tensor:
        rho, tau_y, K, n, mu, lam = values.unbind()
        return _layout(density=rho, tau_y=tau_y, K=K, n=n, mu=mu, lam=lam)

    def wave_speed(self) -> float:
        return math.sqrt((self.lam + 2.0 * self.mu) / self.density)


@dataclass(frozen=True)
class Plasticine(Material):
    """Rate-independent von Mises plasticity on Hencky strain (PAC-NeRF's plasticine)."""

    model: ClassVar[int] = k.MODEL_PLASTICINE
    tau_y: float = 100.0
    mu: float = 1.0e4
    lam: float = 1.0e4

    def __post_init__(self) -> None:
        super().__post_init__()
        _check("tau_y", self.tau_y, strict=False)
        _check("mu", self.mu)
        _check("bulk modulus lam + 2 mu / 3", self.lam + 2.0 * self.mu / 3.0)

    def kernel_vector(self, values: torch.Tensor) -> torch.Tensor:
        rho, tau_y, mu, lam = values.unbind()
        return _layout(density=rho, tau_y=tau_y, mu=mu, lam=lam)

    def wave_speed(self) -> float:
        return math.sqrt((self.lam + 2.0 * self.mu) / self.density)


@dataclass(frozen=True)
class NewtonianFluid(Material):
    """Weakly compressible Newtonian fluid: deviatoric stress 2 viscosity D, pressure from the volume change."""

    model: ClassVar[int] = k.MODEL_NEWTONIAN
    viscosity: float = 1.0
    bulk_modulus: float = 1.0e4

    def __post_init__(self) -> None:
        super().__post_init__()
        _check("viscosity", self.viscosity, strict=False)
        _check("bulk_modulus", self.bulk_modulus)

    def kernel_vector(self, values: torch.Tensor) -> torch.Tensor:
        rho, viscosity, bulk = values.unbind()
        return _layout(density=rho, K=viscosity, lam=bulk)

    def wave_speed(self) -> float:
        return math.sqrt(self.bulk_modulus / self.density)

    def diffusive_time_step(self, dx: float) -> float:
        if self.viscosity == 0.0:
            return math.inf
        return 0.25 * self.density * dx * dx / self.viscosity


@dataclass(frozen=True)
class NeoHookean(Material):
    """Compressible neo-Hookean solid: J T = mu (F F^T - I) + lam log(J) I."""

    model: ClassVar[int] = k.MODEL_NEO_HOOKEAN
    mu: float = 1.0e4
    lam: float = 1.0e4

    def __post_init__(self) -> None:
        super().__post_init__()
        _check("mu", self.mu)
        _check("bulk modulus lam + 2 mu / 3", self.lam + 2.0 * self.mu / 3.0)

    def kernel_vector(self, values: torch.Tensor) -> torch.Tensor:
        rho, mu, lam = values.unbind()
        return _layout(density=rho, mu=mu, lam=lam)

    def wave_speed(self) -> float:
        return math.sqrt((self.lam + 2.0 * self.mu) / self.density)


MATERIALS: dict[str, type[Material]] = {
    "herschel_bulkley": HerschelBulkley,
    "plasticine": Plasticine,
    "newtonian": NewtonianFluid,
    "neo_hookean": NeoHookean,
}


def make_material(name: str, **params: float) -> Material:
    """Build a material by name; ``bingham`` takes tau_y, eta, mu, lam. Unknown names or keys raise MaterialError."""
    if name == "bingham":
        allowed = {"tau_y", "eta", "mu", "lam", "density"}
        unknown = set(params) - allowed
        if unknown:
            raise MaterialError(f"unknown parameter(s) {sorted(unknown)} for material 'bingham'; "
                                f"allowed: {sorted(allowed)}")
        defaults = {"tau_y": HerschelBulkley.tau_y, "eta": 10.0, "mu": HerschelBulkley.mu, "lam": HerschelBulkley.lam}
        return HerschelBulkley.bingham(**{**defaults, **params})
    if name not in MATERIALS:
        raise MaterialError(f"unknown material {name!r}; known materials: {sorted([*MATERIALS, 'bingham'])}")
    cls = MATERIALS[name]
    allowed = {f.name for f in fields(cls)}
    if "bulk_modulus" in params and "lam" in allowed:
        if "lam" in params:
            raise MaterialError(f"material {name!r}: give lam or bulk_modulus, not both")
        kappa = params.pop("bulk_modulus")
        params["lam"] = kappa - 2.0 * params.get("mu", cls.mu) / 3.0
    unknown = set(params) - allowed
    if unknown:
        raise MaterialError(f"unknown parameter(s) {sorted(unknown)} for material {name!r}; allowed: {sorted(allowed)}")
    return cls(**params)
