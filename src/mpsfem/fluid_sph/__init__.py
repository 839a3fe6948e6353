"""δ-SPH / δ-SPHC: the weakly compressible SPH fluid behind the fluid-method seam (docs/fluid_sph.md)."""
