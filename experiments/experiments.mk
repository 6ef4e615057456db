# Experiment targets: see experiments/README.md. Included by the top-level Makefile.
