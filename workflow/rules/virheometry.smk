# ViRheometry's real dam-break recordings: each setup folder imported into SI units, its camera checked.


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
        figure="results/virheometry/setups/{setup}/camera_check.png",
    log:
        "logs/virheometry/setups/{setup}/import.log",
    benchmark:
        "benchmarks/virheometry/setups/{setup}/import.tsv"
    wildcard_constraints:
        setup=r"ref_[A-Za-z0-9]+_[0-9.]+_[0-9.]+_[0-9]+",
    params:
        folder=lambda w: str(virheometry_folder(w.setup)),
        scale=config["virheometry"]["scale"],
    script:
        "../../stages/virheometry_import.py"
