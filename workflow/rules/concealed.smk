# Concealed-effect dam breaks: the virtual lab films a Bingham material with one effect the base model lacks (or
# none); the fit and the diagnosis are not told which, and the summary scores what the diagnosis named.


CASE_SCHEMA = load_schema(Path(workflow.basedir) / "workflow/schemas/concealed_case.schema.yaml")


def concealed_cases() -> list[str]:
    return sorted(p.stem for p in Path(config["concealed"]["cases"]).glob("*.yaml"))


def concealed_suite() -> dict | None:
    """How the cases were drawn (seed, count), for a folder that ``rheo.experiments.suite`` wrote; None otherwise."""
    path = Path(config["concealed"]["cases"]) / "suite.json"
    return json.loads(path.read_text()) if path.is_file() else None


def concealed_case(name: str) -> dict:
    """The case file, validated against its schema."""
    path = Path(config["concealed"]["cases"]) / f"{name}.yaml"
    if not path.is_file():
        raise ConfigError(f"{path}: no such concealed case")
    case = load_named(path, CASE_SCHEMA)
    channels = len(config["concealed"]["scene"]["setups"])
    if len(case.get("channels", [None] * channels)) != channels:
        raise ConfigError(f"{path}: {len(case['channels'])} channels given, the scene films {channels}")
    return case


def concealed_recordings(kind: str) -> list[str]:
    """The paths of a case's recordings (``kind``: setup.json or masks.npz), one per channel of the scene."""
    return [f"results/concealed/{{case}}/recording/{k}/{kind}"
            for k in range(1, len(config["concealed"]["scene"]["setups"]) + 1)]


def concealed_fit_settings() -> dict:
    return {**config["concealed"]["fit"], "flow_index": 1.0}


rule concealed_synthesize:
    input:
        lambda w: str(Path(config["concealed"]["cases"]) / f"{w.case}.yaml"),
    output:
        setups=concealed_recordings("setup.json"),
        masks=concealed_recordings("masks.npz"),
        truth="results/concealed/{case}/truth.json",
    resources:
        mem_mb=2000,
        runtime=30,
    log:
        "logs/concealed/{case}/synthesize.log",
    benchmark:
        "benchmarks/concealed/{case}/synthesize.tsv"
    wildcard_constraints:
        case=r"[A-Za-z0-9_.]+",
    params:
        case=lambda w: concealed_case(w.case),
        scene=config["concealed"]["scene"],
        lab=config["concealed"]["lab"],
        truth=config["concealed"]["truth"],
        elastic=[config["virheometry"]["simulation"]["mu"], config["virheometry"]["simulation"]["lam"]],
    script:
        "../../stages/concealed_synthesize.py"


rule concealed_fit:
    input:
        setups=concealed_recordings("setup.json"),
        masks=concealed_recordings("masks.npz"),
    output:
        params="results/concealed/{case}/fit/params.json",
        history="results/concealed/{case}/fit/history.csv",
        frames="results/concealed/{case}/fit/frames.png",
    resources:
        mem_mb=worker_memory(800, 600),
        runtime=90,
    log:
        "logs/concealed/{case}/fit.log",
    benchmark:
        "benchmarks/concealed/{case}/fit.tsv"
    wildcard_constraints:
        case=r"[A-Za-z0-9_.]+",
    threads: job_threads()
    params:
        simulation=virheometry_held_out_simulation(),
        settings=concealed_fit_settings(),
    script:
        "../../stages/virheometry_fit.py"


rule concealed_oracle:
    input:
        truth="results/concealed/{case}/truth.json",
        setups=concealed_recordings("setup.json"),
        masks=concealed_recordings("masks.npz"),
    output:
        "results/concealed/{case}/oracle.json",
    resources:
        mem_mb=worker_memory(800, 600),
        runtime=30,
    log:
        "logs/concealed/{case}/oracle.log",
    wildcard_constraints:
        case=r"[A-Za-z0-9_.]+",
    params:
        simulation=virheometry_held_out_simulation(),
    script:
        "../../stages/concealed_oracle.py"


rule concealed_summary:
    input:
        diagnoses=expand("results/concealed/{case}/diagnosis/diagnosis.json", case=concealed_cases()),
        truths=expand("results/concealed/{case}/truth.json", case=concealed_cases()),
        fits=expand("results/concealed/{case}/fit/params.json", case=concealed_cases()),
        oracles=expand("results/concealed/{case}/oracle.json", case=concealed_cases()),
    output:
        html="results/concealed/summary.html",
        scores="results/concealed/summary.json",
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/concealed/summary.log",
    params:
        cases=concealed_cases(),
        candidates=config["diagnose"]["candidates"],
        suite=concealed_suite(),
    script:
        "../../stages/concealed_summary.py"
