"""Evaluation: segmentation metrics, the PSB data, the benchmark and its report, and
timing scripts for loading and signatures."""
