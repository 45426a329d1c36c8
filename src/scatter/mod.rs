//! Single scattering through refractive triangle meshes with interpolated normals (Holzschuch 2013).
