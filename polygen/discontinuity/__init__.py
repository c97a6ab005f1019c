"""Chapter 3: simplified discontinuity meshing with shadow polyhedra."""
