"""The main window's panels (Qt widgets). Each shows one part of the model and forwards the
user's actions to the model or a controller; none holds state of its own beyond its widgets."""
