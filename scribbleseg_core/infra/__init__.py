"""Infrastructure with no knowledge of meshes: atomic file writes and the on-disk array cache."""
