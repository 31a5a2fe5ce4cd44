"""The paper's own artefacts: N/Le, Fig. 2, Tables 1-3 and the consistency checks."""
