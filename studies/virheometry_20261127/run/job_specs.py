"""What the job-spec scripts share: the checkout's config, validated, for a device, and a diagnosis' jobs (whole,
or split by candidate) as Snakemake's rule would give them to the stage script."""
import os
from pathlib import Path

from rheo.config import load_schema, load_yaml, validated


def load_config(device: str, overrides: dict) -> dict:
    """config/config.yaml with ``overrides`` (section: its keys) and the schema's defaults, simulating on ``device``."""
    config = load_yaml("config/config.yaml")
    for section, values in overrides.items():
        config[section] = {**config.get(section, {}), **values}
    validated(config, load_schema(Path("workflow/schemas/config.schema.yaml")), "config")
    config["simulation"]["device"] = device
    return config


def held_out_simulation(config: dict) -> dict:
    """The simulation of fits that hold frames out, as virheometry_held_out_simulation() in the rules."""
    return {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}


def diagnosis_jobs(config: dict, name: str, which: str, inputs: dict, rheometer: list[str] | None, folder: str,
                   log_folder: str, fit_settings: dict, title: str, after: str | None = None) -> list[dict]:
    """The diagnosis ``name`` of the fit and recordings ``inputs`` (fit, setups, masks; the whole diagnosis also reads
    the ``rheometer`` curves where the rule names that input), its outputs in ``folder``: whole under the tolerant
    replay on all cores where ``which`` is empty, else split by candidate (names joined by ",", or "*" for all), one
    process each, started after the job ``after``."""
    params = {"settings": config["diagnose"], "fit_settings": fit_settings, "simulation": held_out_simulation(config)}
    if not which:
        whole = inputs if rheometer is None else {**inputs, "rheometer": rheometer}
        return [{"name": name, "script": "tolerant_diagnose.py", "input": whole,
                 "output": {"diagnosis": f"{folder}/diagnosis.json", "maps": f"{folder}/maps.png",
                            "report": f"{folder}/report.html"},
                 "log": [f"{log_folder}/diagnose.log"], "threads": os.cpu_count(),
                 "params": {**params, "title": title}, "config": config}]
    candidates = config["diagnose"]["candidates"] if which == "*" else which.split(",")
    return [{"name": f"{name}.{c}", "script": "candidate.py", **({"after": after} if after else {}),
             "input": {**inputs, "evaluations": f"{folder}/diagnosis.evaluations.json"},
             "output": {"done": f"{folder}/{c}.done"}, "log": [f"{log_folder}/diagnose.{c}.log"], "threads": 1,
             "params": {**params, "candidate": c}, "config": config} for c in candidates]
