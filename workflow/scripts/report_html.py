# Snakemake script for rule report_html: the executed report notebook -> one offline HTML
# (mrhyst.report.offline.export_html).
from mrhyst.logs import to_log
from mrhyst.report import offline as report

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    report.export_html(sm.input.nb, sm.output[0], sm.input.template)
