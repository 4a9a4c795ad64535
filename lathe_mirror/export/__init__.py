"""Everything that writes files: G-code, CAD, meshes, POV-Ray scenes (and report/)."""
