# numba's cache filled before the first jobs run (mrhyst.warmup): two jobs, one per core, each compiling its own
# group of kernels, so that the jobs that start the build (the key's draws, the external fits) do not each compile
# the same kernels at once (~9-10 CPU s per kernel group and job on a fresh clone). Their outputs are `ancient`
# inputs of those rules: a warm-up that runs again (new code) never makes a result out of date.


rule warmup:
    output:
        "results/warmup/{group}.json",
    wildcard_constraints:
        group="ja|variants",
    log:
        "results/logs/warmup_{group}.log",
    priority: 20  # before everything: the jobs that need the kernels wait for them
    threads: 1
    script:
        "../scripts/warmup.py"


def warmed(group):
    """The warm-up of ``group`` as a rule input (existence only: see above)."""
    return ancient(f"results/warmup/{group}.json")
