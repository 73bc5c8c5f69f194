"""Layer 6: what a user reads: plots and the files of a run or a front."""
