# Shared helpers and wildcard constraints.

wildcard_constraints:
    number=r"[0-9.eE+-]+",


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
