# The convergence study of a material's simulated dam breaks: laws on a sequence of grids and time steps.


def convergence_folders(material: str) -> list[Path]:
    """The material's setup folders, which the study reads itself (at virheometry.fps)."""
    return setup_folders(config["virheometry"]["data"], material)


def convergence_laws(material: str) -> dict:
    laws = config["virheometry"]["convergence"]["laws"].get(material, {})
    if not laws and material not in config["virheometry"]["rheometer"]:
        raise ValueError(f"{material}: no law to study (virheometry.convergence.laws has none, no rheometer curves)")
    return laws


rule virheometry_convergence:
    input:
        recordings=lambda w: sorted(str(f) for p in convergence_folders(w.material)
                                    for f in p.iterdir() if f.suffix in {".xml", ".png"}),
        rheometer=lambda w: config["virheometry"]["rheometer"].get(w.material, []),
    output:
        report=report("results/virheometry/{material}/convergence.html", caption="../report/convergence.rst",
                      category="Real dam breaks", subcategory="{material}"),
        summary="results/virheometry/{material}/convergence.json",
    resources:
        mem_mb=worker_memory(800, 600),
        runtime=240,
    log:
        "logs/virheometry/{material}/convergence.log",
    benchmark:
        "benchmarks/virheometry/{material}/convergence.tsv"
    wildcard_constraints:
        material=r"[A-Za-z0-9]+",
    threads: job_threads()
    params:
        folders=lambda w: [str(p) for p in convergence_folders(w.material)],
        laws=lambda w: convergence_laws(w.material),
        study={k: v for k, v in config["virheometry"]["convergence"].items() if k != "laws"},
        simulation=config["virheometry"]["simulation"],
        scale=config["virheometry"]["scale"],
        fps=config["virheometry"]["fps"],
    script:
        "../../stages/virheometry_convergence.py"
