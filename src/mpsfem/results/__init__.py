"""Results file (HDF5 contract of the design brief), checkpoints and the ParaView sidecar."""
