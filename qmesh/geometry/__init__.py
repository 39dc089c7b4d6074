"""Plain geometry shared by the mesher and the measures: per-triangle areas, metric quality and
Hessians (`triangles`), polygon rings (`rings`), the half-edge topology (`topology`) and
quadrature rules (`quadrature`)."""
