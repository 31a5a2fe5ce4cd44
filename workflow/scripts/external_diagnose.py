# Snakemake script for rule external_diagnose: every loop of one third-party B(H) file diagnosed
# (mrhyst.diagnose.diagnose_bh_source; issue 13): the verdict table of the report's appendix, and the figure of
# each loop's diagnosis (mrhyst.report.diagfig, issue 26) in output.figs.
from pathlib import Path

from mrhyst.data.io import write_json
from mrhyst.diagnose import diagnose_bh_source, resolve_config
from mrhyst.diagnose.core import bh_material
from mrhyst.logs import to_log
from mrhyst.materials.extsettings import loop_fit_settings
from mrhyst.report import diagfig

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    figs = Path(sm.output.figs)
    figs.mkdir(parents=True, exist_ok=True)
    src = sm.wildcards.source

    def figure(idx, d):
        name = src if idx is None else f"{src} loop {idx}"
        diagfig.save(d, figs / f"{src}{'' if idx is None else f'_loop{idx}'}.png", name=name)

    settings = resolve_config(sm.params.config["diagnose"])  # once, at the boundary: what runs is recorded
    # the material fit's sections (ja, pso, lsm, external) as the B(H) diagnosis runs them (its own search starts)
    material = bh_material(loop_fit_settings(sm.params.config), settings)
    rows = diagnose_bh_source(sm.input.csv, settings, each=figure, material=material)
    write_json({"source": src, "path": sm.input.csv, "settings": settings.as_dict(),
                "material_fit_settings": material.as_dict(), "loops": rows}, sm.output.json)
