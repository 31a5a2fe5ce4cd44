"""Names of the J-A model that need no numerics (the command line's choices, read before numba is loaded)."""

PARAM_NAMES = ("Ms", "a", "alpha", "c", "k")  # the classic parameters, in the order of every array
FORMS = ("paper", "physical")
