"""The conductivity as a field (qmesh.TensorField): element means, box means and refusals."""
