// PLY triangle-mesh reader for Shape "plymesh": ascii and binary (little and big endian).
#pragma once
#include <string>
#include <vector>

#include "scene/scene.h"

namespace basalt {

/// \brief Reads a PLY file into an object-space triangle mesh.
///
/// Reads `vertex` (x y z; optional nx ny nz; optional u v, s t, texture_u texture_v or
/// texture_s texture_t), `face` (list `vertex_indices` or `vertex_index`, any integer types;
/// polygons are fan-triangulated) and `tristrips` (list `vertex_indices`, -1 restarts a strip;
/// triangle k of a strip is (k, k+1, k+2) with every odd one's first two vertices swapped to keep
/// the winding, and triangles repeating a vertex are dropped). Other elements are skipped.
/// \param warnings receives notes on skipped faces, without a location prefix (may be null).
/// \param max_table_bytes the largest vertex or triangle table the renderer takes: a header
///        declaring more vertices or faces is refused before the body is read.
/// \throws SceneError whose location is the file (no line) for a missing, unreadable, malformed
///         or truncated file (element counts are checked against the file size first), a value
///         out of its type's range, or an index out of range.
TriangleMesh load_ply(const std::string& path, std::vector<std::string>* warnings = nullptr,
                      std::uint64_t max_table_bytes = kMaxTableBytes);

}  // namespace basalt
