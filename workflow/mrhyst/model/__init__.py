"""The forward model: the J-A kernel and its variants, the effects, the Hall chain."""
