"""The finite-element model: Gmsh mesh of the blocks, elasticity, joint node pairs, the fill."""
