"""Third-party measured loops: per-loop and joint fits (the joint problem is mrhyst.fit.joint, the loop figures
a materials lab reads mrhyst.data.loopfigures: layers below this one)."""
