# Shared helpers and wildcard constraints.
import functools
import glob
import json
from pathlib import Path

from rheo.config import ConfigError, load_named, load_schema, load_yaml
from rheo.experiments.cost import check_cost, experiment_cost

EXPERIMENT_SCHEMA = load_schema(Path(workflow.basedir) / "workflow/schemas/experiment.schema.yaml")

wildcard_constraints:
    # results/thesis and results/virheometry hold the thesis' tables and the real dam breaks, not experiments
    experiment=r"(?!(?:thesis|virheometry)/)[A-Za-z0-9_]+",


def job_threads():
    """Worker processes of the rules that run simulations side by side: config's threads_per_job, else every core
    Snakemake is given (--cores; on a cluster without --cores, two, unless the profile sets them)."""
    if config["threads_per_job"]:
        return config["threads_per_job"]
    try:
        return max(1, int(workflow.cores or 1))
    except WorkflowError:  # a cluster executor and no --cores
        return 2


def worker_memory(base_mb, per_worker_mb):
    """A rule's memory (MB): its own and its workers', from the benchmarks (docs/performance.md)."""
    return lambda wildcards, threads: base_mb + per_worker_mb * threads


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
    """The experiment config/experiments/<name>.yaml, validated against its schema (defaults filled in) and its
    estimated cost within config's limits."""
    path = Path("config/experiments") / f"{name}.yaml"
    if not path.is_file():
        raise ConfigError(f"{path}: no such experiment config")
    # keys sorted, so that params (compared as text by Snakemake) do not change with the order in the file
    return json.loads(_checked_experiment(path, path.stat().st_mtime_ns))


@functools.cache
def _checked_experiment(path, modified):
    exp = load_named(path, EXPERIMENT_SCHEMA)
    check_cost(experiment_cost(exp), config["limits"], str(path))
    return json.dumps(exp, sort_keys=True)


def calibration_images(name):
    """Every camera's checkerboard images and floor-board image; a pattern that matches nothing is refused."""
    files = set()
    for camera, cam in calibration_config(name)["cameras"].items():
        matched = glob.glob(cam["images"])
        if not matched:
            raise ConfigError(f"config/experiments/{name}.yaml: calibration.cameras.{camera}.images: the pattern "
                              f"{cam['images']!r} matches no file (relative to {Path.cwd()})")
        if not Path(cam["ground_image"]).is_file():
            raise ConfigError(f"config/experiments/{name}.yaml: calibration.cameras.{camera}.ground_image: no such "
                              f"file {cam['ground_image']!r}")
        files.update(matched)
        files.add(cam["ground_image"])
    return sorted(files)


def calibration_config(name):
    """The calibration settings: the experiment's own, or for a virtual experiment the lab's board and images."""
    exp = experiment(name)
    if exp["kind"] != "virtual":
        return exp["calibration"]
    lab, rec = exp["lab"], f"results/{name}/recordings"
    x, z = lab["ground_origin"]
    cameras = {f"cam{c:02d}": {"images": f"{rec}/cam{c:02d}/checkerboard/*.png",
                               "ground_image": f"{rec}/cam{c:02d}/ground_board.png", "ground_origin": [x, 0.0, z]}
               for c in range(exp["cameras"]["count"])}
    return {"board": lab["board"], "fix_aspect_ratio": True, "min_views": 3, "silhouette_refinement": False,
            "board_tolerance": 0.0005, "cameras": cameras}


def calibration_inputs(name):
    """Named inputs of calibrate: the images (or the lab's recordings and their truth), and the matte and proxy for
    a silhouette refinement."""
    if experiment(name)["kind"] == "virtual":
        return {"images": [f"results/{name}/recordings"], **truth_input(name)}
    inputs = {"images": calibration_images(name)}
    if experiment(name)["calibration"]["silhouette_refinement"]:
        inputs.update(matte=f"results/{name}/matte", proxy=f"results/{name}/proxy/particles.npz")
    return inputs


def virtual_experiment(name):
    """The parts of a virtual experiment that the virtual lab depends on (not matting or fitting settings)."""
    exp = experiment(name)
    if exp["kind"] != "virtual":
        raise ValueError(f"config/experiments/{name}.yaml: synthesize needs a virtual experiment (kind: virtual)")
    return {key: exp[key] for key in ("name", "proxy", "material", "simulation", "cameras", "lab")}


def experiments_of_kind(kind):
    """A wildcard pattern matching the experiments of one kind (virtual or real), from config/experiments. A file
    that cannot be read counts as real, so that only its own targets fail, with experiment()'s message."""
    names = []
    for path in sorted(Path("config/experiments").glob("*.yaml")):
        try:
            content = load_yaml(path)
            virtual = isinstance(content, dict) and content.get("kind") == "virtual"
        except ConfigError:
            virtual = False
        if ("virtual" if virtual else "real") == kind:
            names.append(path.stem)
    return "|".join(names) if names else "(?!)"


def recording_config(name):
    exp = experiment(name)
    if "recording" not in exp:
        raise ValueError(f"config/experiments/{name}.yaml: a real experiment needs a recording section to ingest")
    return exp["recording"]


def recording_sources(name):
    files = []
    for cam in recording_config(name)["cameras"].values():
        files.append(cam["source"])
        if cam.get("clean_plate"):
            files.append(cam["clean_plate"])
    return files


def truth_input(name):
    """The virtual lab's truth.json as a named input, for stages that score themselves against it."""
    return {"truth": f"results/{name}/truth.json"} if experiment(name)["kind"] == "virtual" else {}
