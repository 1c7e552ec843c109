"""Per-face shape signatures: AGD, SDF, Gaussian curvature, SI-HKS (the paper's 22 values),
their on-disk cache, and the multi-scale context the network also reads."""
