"""config.py - the benchmark's configuration: datasets, parameter sweeps, series, seeds."""


# name -> (dataset arguments, kind); kind 'chess' marks the chessboards of the NMF goal.
FULL_DATASETS = {
    "chess4x4": (["chess4x4"], "chess"),
    "chess8x8": (["chess8x8"], "chess"),
    "veined-marble": (["veined-marble"], "marble"),
    # Monte Carlo at the paper's pixel pitch (12.6 cm / 277) on a 64 x 64 patch.
    "chess4x4-mc": (["chess4x4", "--generator", "montecarlo", "--pixels", "64x64",
                     "--size-cm", "2.91x2.91", "--photons", "1000"], "mc"),
}


QUICK_DATASETS = {
    "chess4x4": (["chess4x4", "--pixels", "24x24", "--kernel", "9"], "chess"),
    "chess8x8": (["chess8x8", "--pixels", "24x24", "--kernel", "9"], "chess"),
    "veined-marble": (["veined-marble", "--pixels", "24x24", "--kernel", "9"], "marble"),
    "chess4x4-mc": (["chess4x4", "--generator", "montecarlo", "--pixels", "12x12", "--kernel",
                     "9", "--size-cm", "2x2", "--photons", "100"], "mc"),
}


# Parameter sweeps: (method, {option: value}); raw is the reference.
FULL_SWEEP = (
    [("raw", {})]
    + [("svd", {"T": t}) for t in (1, 2, 4, 10, 16, 24, 40)]
    + [("tucker", {"T": t, "P": p}) for t, p in ((5, 4), (10, 7), (15, 7), (40, 7))]
    + [("kcta", {"C": c, "Km": k, "T": t}) for c, k, t in ((8, 1, 4), (8, 2, 4), (16, 2, 4),
                                                          (16, 1, 2), (24, 1, 2), (16, 1, 4),
                                                          (32, 1, 4), (32, 2, 4))]
    + [("nmf", {"T": t}) for t in (5, 10, 20, 40)]
    + [("nmf", {"E": 0, "T": t}) for t in (5, 10, 20)]
)


QUICK_SWEEP = (
    [("raw", {})]
    + [("svd", {"T": t}) for t in (2, 4)]
    + [("tucker", {"T": 3, "P": 2})]
    + [("kcta", {"C": 2, "Km": 1, "T": 2})]
    + [("nmf", {"T": t}) for t in (2, 4)]
    + [("nmf", {"E": 0, "T": 4})]
)


OPTION = {"T": "-T", "P": "-P", "C": "-C", "Km": "--km", "E": "--homog-exp"}


METHODS = ("svd", "tucker", "kcta", "nmf", "raw")


# A series is a method, or nmf with a --homog-exp other than 1: "nmf" is the issue's baseline
# (Peers et al.'s division by the homogeneous approximation), "nmf E=0" is NMF of Rd itself,
# which this benchmark also runs because it is the stronger baseline on these datasets.
SERIES = ("svd", "tucker", "kcta", "nmf", "nmf E=0")


OPALINE_SERIES = ("svd", "tucker", "kcta")


NMF_SERIES = {"nmf": "NMF of the remainder after Peers et al.'s division (E=1; the issue's "
                     "baseline)",
              "nmf E=0": "NMF of Rd itself (E=0, no division; a stronger baseline than the "
                         "issue names)"}


COLOURS = {"svd": "tab:blue", "tucker": "tab:orange", "kcta": "tab:green", "nmf": "tab:red",
           "nmf E=0": "tab:purple", "raw": "black"}


SEED = 1           # dataset generator seed


RANDOM_STATE = 0   # scikit-learn's seed


LOG_A, LOG_B = 100.0, 1.0   # opaline's svd defaults (docs/formats.md)


SLOW_SECONDS = 60.0  # a configuration runs at most this long in all, unless one run is longer


TYPICAL = {"svd": {"T": 10}, "tucker": {"T": 15, "P": 7}, "kcta": {"C": 8, "Km": 2, "T": 4},
           "nmf": {"T": 10}, "raw": {}}


QUICK_TYPICAL = {"svd": {"T": 4}, "tucker": {"T": 3, "P": 2}, "kcta": {"C": 2, "Km": 1, "T": 2},
                 "nmf": {"T": 4}, "raw": {}}
