"""Files and paths: the contract formats (clear errors) and the shape of any current path."""
