"""The simulated material's steady flow curve: Lotion's two laws (the Bingham fit at the default settings and the
rheometer's law) sheared at constant rates through the engine's constitutive update, at the dam breaks' shear
modulus and a stiffer one, until the stress settles; its shear stress and first normal stress difference against the
nominal tau_y + K gamma_dot^n. Writes ``--out`` (JSON).

    PYTHONPATH=. python studies/simple_shear_20261128/run/flow_curve.py \
        --out studies/simple_shear_20261128/flow_curve.json
"""

import argparse
from pathlib import Path

import numpy as np
import warp as wp

from rheo.config import WORKFLOW_CONFIG, workflow_settings
from rheo.io import write_json_atomic
from rheo.physics import HerschelBulkley, kernels
from studies.lotion import lotion_laws

RATES = (0.3, 1.0, 3.0, 10.0, 30.0, 100.0)  # 1/s
STRAIN = 3.0  # shear strain at the slowest rate
STEP = 3e-4  # s, about a dam break's step at the default settings


def steady_stress(material: HerschelBulkley, rates: np.ndarray) -> np.ndarray:
    """The Kirchhoff stress (rates, 3, 3) after ``STRAIN`` of simple shear v_x = gamma_dot y at the slowest rate."""
    k = kernels.build(wp.float64)
    gradient = np.zeros((len(rates), 3, 3))
    gradient[:, 0, 1] = rates
    F, F_next = (wp.array(np.tile(np.eye(3), (len(rates), 1, 1)), dtype=k.mat33) for _ in range(2))
    tau = wp.zeros(len(rates), dtype=k.mat33)
    mat = wp.array(material.kernel_vector(material.parameters()).numpy(), dtype=wp.float64)
    velocity_gradient, structure = wp.array(gradient, dtype=k.mat33), wp.zeros(len(rates), dtype=wp.float64)
    for _ in range(round(STRAIN / rates.min() / STEP)):
        wp.launch(k.return_mapping, len(rates), inputs=[F, velocity_gradient, mat, material.model, wp.float64(STEP),
                                                        structure, wp.float64(0.0), wp.float64(0.0), F_next, tau])
        F, F_next = F_next, F
    return tau.numpy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--mu", type=float, nargs="+", default=[300.0, 3000.0], help="shear moduli (Pa)")
    args = parser.parse_args()
    config = workflow_settings(WORKFLOW_CONFIG)["virheometry"]
    lam = config["simulation"]["lam"]
    laws = lotion_laws(config)
    rates = np.array(RATES)
    out = {"rates_per_s": list(RATES), "lam_pa": lam, "step_s": STEP, "strain": STRAIN, "laws": {}}
    for name, (tau_y, K, n) in laws.items():
        nominal = tau_y + K * rates**n
        out["laws"][name] = {"law": [tau_y, K, n], "nominal_pa": nominal.tolist(), "by_mu": {}}
        for mu in args.mu:
            tau = steady_stress(HerschelBulkley(tau_y=tau_y, K=K, n=n, mu=mu, lam=lam), rates)
            shear = tau[:, 0, 1]
            out["laws"][name]["by_mu"][f"{mu:g}"] = {"shear_pa": shear.tolist(), "ratio": (shear / nominal).tolist(),
                                                     "n1_pa": (tau[:, 0, 0] - tau[:, 1, 1]).tolist()}
            ratios = " ".join(f"{r:g}/s {s / v:.3f}" for r, s, v in zip(RATES, shear, nominal, strict=True))
            print(name, f"mu {mu:g}:", ratios)
    write_json_atomic(args.out, out)


if __name__ == "__main__":
    main()
