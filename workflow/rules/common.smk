# Shared helpers and wildcard constraints.
import glob
from pathlib import Path

import yaml

wildcard_constraints:
    experiment=r"[A-Za-z0-9_]+",


def collapse_config():
    return config["thesis"]["collapse"]


def table_rows(table):
    """Row keys of a thesis table as strings (the wildcard values)."""
    return [str(float(k)) for k in collapse_config()[table]["rows"]]


def elastic_candidates():
    """(mu, lam) pairs tried in the calibration, as wildcard strings."""
    cfg = collapse_config()
    return [(str(float(mu)), str(float(mu * ratio))) for mu in cfg["mu_candidates"]
            for ratio in cfg["lam_over_mu_candidates"]]


def simulation_setup():
    """The keys of the collapse configuration that every simulation depends on."""
    keys = ("domain_size", "resolution", "radius", "height", "density", "gravity", "duration", "frames")
    return {k: collapse_config()[k] for k in keys}


def experiment(name):
    """The experiment config/experiments/<name>.yaml, validated against its schema (defaults filled in)."""
    path = Path("config/experiments") / f"{name}.yaml"
    if not path.is_file():
        raise ValueError(f"{path}: no such experiment config")
    with open(path) as f:
        exp = yaml.safe_load(f) or {}
    validate(exp, str(Path(workflow.basedir) / "workflow/schemas/experiment.schema.yaml"))
    if exp["name"] != name:
        raise ValueError(f"{path}: name {exp['name']!r} differs from the file name {name!r}")
    return exp


def calibration_images(name):
    cams = experiment(name)["calibration"]["cameras"]
    files = set()
    for cam in cams.values():
        files.update(glob.glob(cam["images"]))
        files.add(cam["ground_image"])
    return sorted(files)
