"""Third-party measured loops: per-loop and joint fits, the loop figures a materials lab reads."""
