# ViRheometry's real dam-break recordings: each setup folder imported into SI units, its camera checked.

from rheo.experiments.virheometry import setup_folders


def virheometry_folder(setup: str) -> Path:
    folder = Path(config["virheometry"]["data"]) / setup
    if not folder.is_dir():
        raise ValueError(f"{folder}: no such ViRheometry setup folder")
    return folder


rule virheometry_import:
    input:
        lambda w: sorted(str(p) for p in virheometry_folder(w.setup).iterdir() if p.suffix in {".xml", ".png"}),
    output:
        setup="results/virheometry/setups/{setup}/setup.json",
        masks="results/virheometry/setups/{setup}/masks.npz",
        figure=report("results/virheometry/setups/{setup}/camera_check.png", caption="../report/camera_check.rst",
                      category="Real dam breaks", subcategory="camera checks"),
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/virheometry/setups/{setup}/import.log",
    benchmark:
        "benchmarks/virheometry/setups/{setup}/import.tsv"
    wildcard_constraints:
        setup=r"ref_[A-Za-z0-9]+_[0-9.]+_[0-9.]+_[0-9]+",
    params:
        folder=lambda w: str(virheometry_folder(w.setup)),
        scale=config["virheometry"]["scale"],
        fps=config["virheometry"]["fps"],
    script:
        "../../stages/virheometry_import.py"


def virheometry_setups(material: str) -> list[str]:
    """The setup folders of a material, by setup index."""
    return [p.name for p in setup_folders(config["virheometry"]["data"], material)]


def fitted_setups(material: str, fit: str) -> list[str]:
    """``fit``: all the material's setups (fit, or fit_bingham at n = 1) or one of them (fit_setup<k>)."""
    setups = virheometry_setups(material)
    if fit in ("fit", "fit_bingham"):
        return setups
    chosen = [s for s in setups if s.rsplit("_", 1)[1] == fit.removeprefix("fit_setup")]
    if not chosen:
        raise ValueError(f"{material}: no setup {fit.removeprefix('fit_setup')} among {setups}")
    return chosen


def virheometry_bingham_settings() -> dict:
    """The Bingham model's fit (n = 1), where a diagnosis starts."""
    return {**config["virheometry"]["fit"], "flow_index": 1.0}


def virheometry_held_out_simulation() -> dict:
    """The simulation of fits that hold out every few frames and the last ones of the recordings (real dam breaks
    and concealed cases alike)."""
    return {**config["virheometry"]["simulation"], "held_out_every": config["diagnose"]["held_out_every"],
            "forecast_share": config["diagnose"]["forecast_share"]}


rule virheometry_fit:
    input:
        setups=lambda w: expand("results/virheometry/setups/{setup}/setup.json", setup=fitted_setups(w.material, w.fit)),
        masks=lambda w: expand("results/virheometry/setups/{setup}/masks.npz", setup=fitted_setups(w.material, w.fit)),
    output:
        params="results/virheometry/{material}/{fit}/params.json",
        history="results/virheometry/{material}/{fit}/history.csv",
        frames="results/virheometry/{material}/{fit}/frames.png",
    resources:
        mem_mb=worker_memory(800, 700),
        runtime=90,
    log:
        "logs/virheometry/{material}/{fit}.log",
    benchmark:
        "benchmarks/virheometry/{material}/{fit}.tsv"
    wildcard_constraints:
        material=r"[A-Za-z0-9]+",
        fit=r"fit|fit_bingham|fit_setup[0-9]+",
    threads: job_threads()
    params:
        simulation=lambda w: virheometry_held_out_simulation() if w.fit == "fit_bingham"
        else config["virheometry"]["simulation"],
        settings=lambda w: virheometry_bingham_settings() if w.fit == "fit_bingham" else config["virheometry"]["fit"],
    script:
        "../../stages/virheometry_fit.py"


rule virheometry_report:
    input:
        params="results/virheometry/{material}/fit/params.json",
        frames="results/virheometry/{material}/fit/frames.png",
        camera_checks=lambda w: expand("results/virheometry/setups/{setup}/camera_check.png",
                                       setup=virheometry_setups(w.material)),
        rheometer=lambda w: config["virheometry"]["rheometer"].get(w.material, []),
        single=lambda w: (expand("results/virheometry/{material}/fit_setup{k}/params.json", material=w.material,
                                 k=[s.rsplit("_", 1)[1] for s in virheometry_setups(w.material)])
                          if w.material in config["virheometry"]["single_setup_fits"] else []),
    output:
        report=report("results/virheometry/{material}/report.html", caption="../report/virheometry_report.rst",
                      category="Real dam breaks", subcategory="{material}"),
        flow_curve="results/virheometry/{material}/flow_curve.png",
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/virheometry/{material}/report.log",
    wildcard_constraints:
        material=r"[A-Za-z0-9]+",
    script:
        "../../stages/virheometry_report.py"


def virheometry_materials() -> list[str]:
    """Every material with a setup folder in the data."""
    names = {p.name.split("_")[1] for p in Path(config["virheometry"]["data"]).glob("ref_*_*_*_*") if p.is_dir()}
    return sorted(names)


def summary_inputs() -> dict:
    """Every material's joint fit and page, and the rheometer curves."""
    materials = virheometry_materials()
    return {"params": expand("results/virheometry/{material}/fit/params.json", material=materials),
            "reports": expand("results/virheometry/{material}/report.html", material=materials),
            "rheometer": [curve for m in materials for curve in config["virheometry"]["rheometer"].get(m, [])]}


rule virheometry_summary:
    input:
        **summary_inputs(),
        diagnoses=expand("results/virheometry/{material}/diagnosis/diagnosis.json", material=virheometry_materials()),
    output:
        report("results/virheometry/summary.html", caption="../report/summary.rst", category="Real dam breaks"),
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        "logs/virheometry/summary.log",
    params:
        materials=virheometry_materials(),
        rheometer={m: config["virheometry"]["rheometer"].get(m, []) for m in virheometry_materials()},
    script:
        "../../stages/virheometry_summary.py"


# the summary's table of fits alone, before the diagnoses have run
use rule virheometry_summary as virheometry_fits with:
    input:
        **summary_inputs(),
    output:
        report("results/virheometry/fits.html", caption="../report/summary.rst", category="Real dam breaks"),
    log:
        "logs/virheometry/fits.log",
