# Snakemake script for rule tables: Tables 1-3 beside the paper, seed spread, identifiability, the paper check.
from pathlib import Path

from mrhyst.data import io
from mrhyst.logs import to_log
from mrhyst.paper import tables as metrics

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    paper = sm.params.config["paper"]
    its = tuple(int(i) for i in sm.params.config["metrics"]["iterations"])
    out = metrics.make_tables(sm.input.fits, paper, Path(sm.output.table1).parent,
                              profile_paths=sm.input.profiles, iterations=its)
    print({k: str(v) for k, v in out.items()})
    sel = metrics.select_median(metrics.load_fits(sm.input.fits))
    io.write_json([{"group": g, "method": m, "setting": s, "seed": f.get("seed"), "rms_T": f["rms_T"],
                    "path": f["_path"]} for (g, m, s), f in sorted(sel.items())], sm.output.selected)
    check = metrics.paper_check(paper, io.read_json(sm.input.nle))
    io.write_json(check, sm.output.paper_check)
    for f in check["checks"]:
        print(("ok    " if f["ok"] else "FAIL  ") + f["text"])
    print(f"{len(check['independent'])} independent inconsistencies")
