"""Pre-integration table builders (plain functions; stages in warpvol.stages wrap them)."""
