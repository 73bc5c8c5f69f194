"""ecostudy's benchmarks: ``bench/harness.py`` (``python -m bench``) and the scripts that are its cases."""
