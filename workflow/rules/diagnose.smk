# diagnose: where a dam-break fit still disagrees with its recordings, which effect the base model left out, the
# refit with it, and the gain on frames held out of every fit.


def diagnose_params(fit_settings, simulation):
    return {"settings": config["diagnose"], "fit_settings": fit_settings, "simulation": simulation}


rule virheometry_diagnose:
    input:
        fit="results/virheometry/{material}/fit_bingham/params.json",
        setups=lambda w: expand("results/virheometry/setups/{setup}/setup.json", setup=virheometry_setups(w.material)),
        masks=lambda w: expand("results/virheometry/setups/{setup}/masks.npz", setup=virheometry_setups(w.material)),
        rheometer=lambda w: config["virheometry"]["rheometer"].get(w.material, []),
    output:
        diagnosis="results/virheometry/{material}/diagnosis/diagnosis.json",
        maps="results/virheometry/{material}/diagnosis/maps.png",
        report=report("results/virheometry/{material}/diagnosis/report.html", caption="../report/diagnosis.rst",
                      category="Diagnosis", subcategory="{material}"),
    resources:
        mem_mb=worker_memory(800, 600),
        runtime=300,
    log:
        "logs/virheometry/{material}/diagnose.log",
    benchmark:
        "benchmarks/virheometry/{material}/diagnose.tsv"
    wildcard_constraints:
        material=r"[A-Za-z0-9]+",
    threads: job_threads()
    params:
        **diagnose_params(virheometry_bingham_settings(), virheometry_held_out_simulation()),
        title=lambda w: f"{w.material}: what the Bingham model leaves out",
    script:
        "../../stages/diagnose.py"


rule concealed_diagnose:
    input:
        fit="results/concealed/{case}/fit/params.json",
        setups=concealed_recordings("setup.json"),
        masks=concealed_recordings("masks.npz"),
    output:
        diagnosis="results/concealed/{case}/diagnosis/diagnosis.json",
        maps="results/concealed/{case}/diagnosis/maps.png",
        report=report("results/concealed/{case}/diagnosis/report.html", caption="../report/diagnosis.rst",
                      category="Diagnosis", subcategory="{case}"),
    resources:
        mem_mb=worker_memory(800, 600),
        runtime=300,
    log:
        "logs/concealed/{case}/diagnose.log",
    benchmark:
        "benchmarks/concealed/{case}/diagnose.tsv"
    wildcard_constraints:
        case=r"[A-Za-z0-9_.]+",
    threads: job_threads()
    params:
        **diagnose_params(concealed_fit_settings(), virheometry_held_out_simulation()),
        title=lambda w: f"concealed case {w.case}: what the Bingham model leaves out",
    script:
        "../../stages/diagnose.py"
