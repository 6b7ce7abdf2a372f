# rheo: Herschel-Bulkley rheology from video through differentiable simulation.
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "config/config.yaml"


validate(config, "workflow/schemas/config.schema.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/thesis.smk"
include: "workflow/rules/calibrate.smk"
include: "workflow/rules/proxy.smk"
include: "workflow/rules/synthesize.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/matte.smk"
include: "workflow/rules/seed.smk"
include: "workflow/rules/velocity.smk"
include: "workflow/rules/fit.smk"
include: "workflow/rules/novel.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/virheometry.smk"
include: "workflow/rules/convergence.smk"
include: "workflow/rules/concealed.smk"
include: "workflow/rules/diagnose.smk"


rule all:
    input:
        "results/thesis/collapse.html",
