"""mrhyst.settings.schema_or: a value not given (None) is the schema's; given values are returned as given."""

from mrhyst import config as cfgmod
from mrhyst.settings import schema_or


def test_given_values_pass_and_none_takes_the_schema():
    d = cfgmod.defaults("rig")
    assert schema_or("rig", form="paper", substeps=3) == {"form": "paper", "substeps": 3}
    assert schema_or("rig", form=None, substeps=3) == {"form": d["form"], "substeps": 3}


def test_given_values_do_not_read_the_schema(monkeypatch):
    """A kernel call per model evaluation asks schema_or with every value given: no copy of the section then."""
    def boom(section=None):
        raise AssertionError("schema read")

    monkeypatch.setattr(cfgmod, "defaults", boom)
    assert schema_or("rig", form="physical", substeps=8) == {"form": "physical", "substeps": 8}
