"""Algorithm 2.1: the loop (`loop`) and its stages — seed (`seeding`, `seeding_varying`),
triangulate (`triangulate`, `conform`), adjust (`adjust`, `boundary`), insert (`insert`) — with
the options, the normalisation of position and scale, the sizing and the diagnosis of thin
domains; each run yields `Step`s (`step`). `qmesh.mesh` and `qmesh.iterate` (`qmesh.meshing`)
call `loop.mesh` / `loop.iterate` for one conductivity, `qmesh.media` for several."""
