// Triangle meshes for the scene loader: file readers (Wavefront OBJ, PLY, Mitsuba .serialized)
// and the built-in shapes (rectangle, cube, disk). Everything is in object space; the loader
// applies to_world afterwards.
#pragma once
#include <stdexcept>
#include <string>
#include "core/mesh_attribute.h"
#include "core/scene_desc.h"

namespace lt {

// A mesh file that cannot be read; the message names the file and what is wrong with it.
struct MeshError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// OBJ (tinyobjloader): all objects/groups merged, polygons triangulated, per-corner attributes
// de-duplicated into vertices. Normals only if every corner has one. flipV: v -> 1 - v.
MeshDesc readObj(const std::string& path, bool flipV);
// PLY: ascii, binary_little_endian, binary_big_endian. Vertex x y z [nx ny nz] [u v | s t |
// texture_u texture_v | texture_s texture_t]; face list vertex_indices / vertex_index (polygons
// fan-triangulated). Property types char..double (int8..float64 spellings too).
// attributes: the other vertex and face properties as Mitsuba's PLY plugin names them
// (core/mesh_attribute.h): r g b / red green blue -> "<element>_color"; fields prefix_x, _y, _z
// (or _r _g _b, _0 _1 _2, _1 _2 _3; 1 or 3 of them, consecutive) -> "<element>_prefix" (an r g b
// group: "<element>_prefix_color"); integer fields normalised to [0, 1] and sRGB-decoded, as
// Mitsuba's Struct conversion does. Others are ignored.
MeshDesc readPly(const std::string& path, MeshAttributes* attributes = nullptr);
// Mitsuba .serialized (format 0x041C, versions 3 and 4), mesh number shapeIndex. `faceNormals`
// is set from the file's flag 0x0010.
MeshDesc readSerialized(const std::string& path, int shapeIndex, bool* faceNormals = nullptr);

// Built-in shapes of Mitsuba, in object space with per-vertex normals and uvs.
MeshDesc makeRectangle();        // [-1,1]^2 in the xy-plane, normal +z
MeshDesc makeCube();             // [-1,1]^3, 24 vertices, outward normals
MeshDesc makeDisk(int segments = 128);  // unit disk in the xy-plane, normal +z, area exactly pi

double meshArea(const MeshDesc& m);
// Angle-weighted vertex normals (what Mitsuba computes for meshes without normals). Leaves
// `normals` empty if some vertex has no well-defined normal.
void computeVertexNormals(MeshDesc& m);
// Checks indices (in range, multiple of 3) and that positions/normals/uvs are finite and sized
// consistently; throws MeshError naming `what`.
void validateMesh(const MeshDesc& m, const std::string& what);

}  // namespace lt
