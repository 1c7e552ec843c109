"""Files the user owns: meshes (OFF, OBJ and trimesh's formats), scribbles, ``.seg`` label
files, label sets, labeled exports and collection folders."""
