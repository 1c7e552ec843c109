"""The segmentation engine: patches and their descriptors, the energy, graph cuts, the
network, the scribble propagation, the alternating optimization and prediction."""
