// ParaView files of a run (docs/architecture.md section 1, "vtkio"): particles and tool surfaces as
// XML VTK datasets (.vtp PolyData, .vtu UnstructuredGrid; binary, zlib-compressed, appended data)
// written and read by Debian's VTK library, which only vtkio/src/vtk_files.cpp includes.
//
// Contract
// - Units SI, bin frame (docs/architecture.md section 10). Array names carry their unit
//   (`velocity_m_s`, `force_N`, `radius_m`); a dimensionless array has none (`layer`).
// - A Dataset is a point set: points n x 3 (row-major), optional triangles (node ids into the points,
//   outward normal by the right-hand rule) and point arrays of n x components values. Without
//   triangles every point is one vertex cell (particles), with triangles the triangles are the cells.
// - Every dataset carries its simulated time as the field array "TimeValue" (what ParaView shows),
//   which read() returns as time_s; the .pvd collections that list the files with the same time are
//   written by adapter::VtkSeries (adapter/output_files.hpp) and read by readCollection().
// - encode() returns the complete file content; the caller writes it with its checked atomic writer
//   (adapter::writeFileAtomically), so a failed write never leaves a half file. encode() throws
//   VtkError for an inconsistent dataset (array size, node id out of range, non-finite time).
// - read() and readCollection() throw VtkError naming the file and what is wrong (missing, not a
//   VTK XML file of the expected type, a point array of another size).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::vtkio {

class VtkError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class ValueType { Float64, Int32 };

struct PointArray {
  std::string name;
  int components = 1;
  std::vector<double> values;  // n x components, row-major (Int32 arrays hold whole numbers)
  ValueType type = ValueType::Float64;
};

struct Dataset {
  double time_s = 0;
  std::vector<double> points;                         // n x 3 (m)
  std::vector<std::array<std::int64_t, 3>> triangles; // empty: one vertex per point
  std::vector<PointArray> arrays;

  std::size_t pointCount() const { return points.size() / 3; }
  // The array named `name`; throws VtkError listing the arrays present.
  const PointArray& array(const std::string& name) const;
};

enum class Format { PolyData, UnstructuredGrid };  // .vtp, .vtu

// The file extension of a format, with the dot.
const char* extension(Format format);

// The XML file content of `data` in `format` (see contract).
std::string encode(const Dataset& data, Format format);

// Reads a .vtp or .vtu file (chosen by its extension) with VTK's XML readers.
Dataset read(const std::filesystem::path& file);

struct CollectionEntry {
  double time_s = 0;
  std::filesystem::path file;  // resolved against the collection's directory
};

// The entries of a .pvd collection in file order, parsed by VTK's XML parser.
std::vector<CollectionEntry> readCollection(const std::filesystem::path& pvd_file);

}  // namespace demfem::vtkio
