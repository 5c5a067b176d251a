// The only file that includes VTK (vtkio/include/demfem/vtkio/vtk_files.hpp has the contract).
#include "demfem/vtkio/vtk_files.hpp"

#include <vtkCellArray.h>
#include <vtkCellType.h>
#include <vtkCommand.h>
#include <vtkDataSet.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkIdList.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <cmath>
#include <cstdlib>

namespace demfem::vtkio {

namespace {

constexpr char kTimeArray[] = "TimeValue";

// Collects VTK's error messages of one algorithm instead of letting VTK print them.
class ErrorCollector : public vtkCommand {
 public:
  static ErrorCollector* New() { return new ErrorCollector; }
  void Execute(vtkObject*, unsigned long, void* call_data) override {
    if (call_data && message.empty()) message = static_cast<const char*>(call_data);
  }
  std::string message;
};

void check(const Dataset& data) {
  const std::size_t n = data.pointCount();
  if (data.points.size() != 3 * n) throw VtkError("VTK dataset: the point array is not n x 3");
  if (!std::isfinite(data.time_s)) throw VtkError("VTK dataset: the time is not finite");
  for (const auto& a : data.arrays)
    if (a.components < 1 || a.values.size() != n * static_cast<std::size_t>(a.components))
      throw VtkError("VTK dataset: point array '" + a.name + "' has " + std::to_string(a.values.size()) +
                     " values, expected " + std::to_string(n) + " x " + std::to_string(a.components));
  for (const auto& t : data.triangles)
    for (const auto id : t)
      if (id < 0 || static_cast<std::size_t>(id) >= n)
        throw VtkError("VTK dataset: a triangle names node " + std::to_string(id) + " of " + std::to_string(n));
}

vtkSmartPointer<vtkDataArray> toVtk(const PointArray& a) {
  vtkSmartPointer<vtkDataArray> out;
  switch (a.type) {
    case ValueType::Float64: out = vtkSmartPointer<vtkDoubleArray>::New(); break;
    case ValueType::Int32: out = vtkSmartPointer<vtkIntArray>::New(); break;
  }
  out->SetName(a.name.c_str());
  out->SetNumberOfComponents(a.components);
  out->SetNumberOfTuples(static_cast<vtkIdType>(a.values.size() / static_cast<std::size_t>(a.components)));
  for (std::size_t k = 0; k < a.values.size(); ++k) out->SetVariantValue(static_cast<vtkIdType>(k), a.values[k]);
  return out;
}

// Points, cells (vertices or triangles), point arrays and the time of `data` on `grid`.
template <class Grid>
void fill(const Dataset& data, Grid& grid) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(data.pointCount()));
  for (std::size_t i = 0; i < data.pointCount(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), data.points[3 * i], data.points[3 * i + 1], data.points[3 * i + 2]);
  grid.SetPoints(points);
  vtkNew<vtkCellArray> cells;
  if (data.triangles.empty()) {
    for (vtkIdType i = 0; i < static_cast<vtkIdType>(data.pointCount()); ++i) cells->InsertNextCell(1, &i);
  } else {
    for (const auto& t : data.triangles) {
      const vtkIdType ids[3] = {t[0], t[1], t[2]};
      cells->InsertNextCell(3, ids);
    }
  }
  if constexpr (std::is_same_v<Grid, vtkPolyData>) {
    if (data.triangles.empty()) grid.SetVerts(cells);
    else grid.SetPolys(cells);
  } else {
    grid.SetCells(data.triangles.empty() ? VTK_VERTEX : VTK_TRIANGLE, cells);
  }
  for (const auto& a : data.arrays) grid.GetPointData()->AddArray(toVtk(a));
  vtkNew<vtkDoubleArray> time;
  time->SetName(kTimeArray);
  time->InsertNextValue(data.time_s);
  grid.GetFieldData()->AddArray(time);
}

template <class Writer>
std::string write(vtkDataObject* grid) {
  vtkNew<Writer> writer;
  vtkNew<ErrorCollector> errors;
  writer->AddObserver(vtkCommand::ErrorEvent, errors);
  writer->SetInputData(grid);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();  // raw binary
  writer->SetCompressorTypeToZLib();
  writer->WriteToOutputStringOn();
  if (writer->Write() != 1 || !errors->message.empty())
    throw VtkError("VTK writer failed: " + (errors->message.empty() ? std::string("no output") : errors->message));
  return writer->GetOutputString();
}

PointArray fromVtk(vtkDataArray& a, const std::filesystem::path& file) {
  if (!a.GetName()) throw VtkError(file.string() + ": a point array has no name");
  PointArray out;
  out.name = a.GetName();
  out.components = a.GetNumberOfComponents();
  out.type = a.GetDataType() == VTK_INT ? ValueType::Int32 : ValueType::Float64;
  const vtkIdType tuples = a.GetNumberOfTuples();
  out.values.reserve(static_cast<std::size_t>(tuples * out.components));
  for (vtkIdType t = 0; t < tuples; ++t)
    for (int c = 0; c < out.components; ++c) out.values.push_back(a.GetComponent(t, c));
  return out;
}

Dataset fromVtk(vtkDataSet& grid, const std::filesystem::path& file) {
  Dataset out;
  const vtkIdType n = grid.GetNumberOfPoints();
  out.points.resize(static_cast<std::size_t>(3 * n));
  for (vtkIdType i = 0; i < n; ++i) grid.GetPoint(i, &out.points[static_cast<std::size_t>(3 * i)]);
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < grid.GetNumberOfCells(); ++c) {
    const int type = grid.GetCellType(c);
    if (type == VTK_VERTEX) continue;
    if (type != VTK_TRIANGLE) throw VtkError(file.string() + ": cell " + std::to_string(c) + " is neither a vertex nor a triangle");
    grid.GetCellPoints(c, ids);
    out.triangles.push_back({ids->GetId(0), ids->GetId(1), ids->GetId(2)});
  }
  vtkPointData* pd = grid.GetPointData();
  for (int k = 0; k < pd->GetNumberOfArrays(); ++k) {
    vtkDataArray* a = pd->GetArray(k);
    if (!a) continue;  // not a numeric array
    out.arrays.push_back(fromVtk(*a, file));
    if (out.arrays.back().values.size() != static_cast<std::size_t>(n * a->GetNumberOfComponents()))
      throw VtkError(file.string() + ": point array '" + out.arrays.back().name + "' does not have one tuple per point");
  }
  vtkDataArray* time = grid.GetFieldData()->GetArray(kTimeArray);
  if (!time || time->GetNumberOfTuples() != 1) throw VtkError(file.string() + ": no TimeValue field (simulated time)");
  out.time_s = time->GetComponent(0, 0);
  return out;
}

template <class Reader>
Dataset readWith(const std::filesystem::path& file) {
  vtkNew<Reader> reader;
  vtkNew<ErrorCollector> errors;
  reader->AddObserver(vtkCommand::ErrorEvent, errors);
  if (!std::filesystem::is_regular_file(file)) throw VtkError(file.string() + ": no such file");
  if (!reader->CanReadFile(file.c_str())) throw VtkError(file.string() + ": not a VTK XML file of its extension's type");
  reader->SetFileName(file.c_str());
  reader->Update();
  if (!errors->message.empty() || reader->GetErrorCode() != 0)
    throw VtkError(file.string() + ": " + (errors->message.empty() ? std::string("VTK reader failed") : errors->message));
  return fromVtk(*reader->GetOutput(), file);
}

}  // namespace

const PointArray& Dataset::array(const std::string& name) const {
  std::string present;
  for (const auto& a : arrays) {
    if (a.name == name) return a;
    present += (present.empty() ? "" : ", ") + a.name;
  }
  throw VtkError("VTK dataset has no point array '" + name + "' (it has: " + present + ")");
}

const char* extension(Format format) {
  switch (format) {
    case Format::PolyData: return ".vtp";
    case Format::UnstructuredGrid: return ".vtu";
  }
  return "";
}

std::string encode(const Dataset& data, Format format) {
  check(data);
  switch (format) {
    case Format::PolyData: {
      vtkNew<vtkPolyData> grid;
      fill(data, *grid.Get());
      return write<vtkXMLPolyDataWriter>(grid);
    }
    case Format::UnstructuredGrid: {
      vtkNew<vtkUnstructuredGrid> grid;
      fill(data, *grid.Get());
      return write<vtkXMLUnstructuredGridWriter>(grid);
    }
  }
  throw VtkError("VTK dataset: unknown format");
}

Dataset read(const std::filesystem::path& file) {
  const auto ext = file.extension().string();
  if (ext == extension(Format::PolyData)) return readWith<vtkXMLPolyDataReader>(file);
  if (ext == extension(Format::UnstructuredGrid)) return readWith<vtkXMLUnstructuredGridReader>(file);
  throw VtkError(file.string() + ": not a .vtp or .vtu file");
}

std::vector<CollectionEntry> readCollection(const std::filesystem::path& pvd_file) {
  if (!std::filesystem::is_regular_file(pvd_file)) throw VtkError(pvd_file.string() + ": no such file");
  vtkNew<vtkXMLDataParser> parser;
  vtkNew<ErrorCollector> errors;
  parser->AddObserver(vtkCommand::ErrorEvent, errors);
  parser->SetFileName(pvd_file.c_str());
  if (parser->Parse() != 1 || !errors->message.empty())
    throw VtkError(pvd_file.string() + ": not XML: " + errors->message);
  vtkXMLDataElement* root = parser->GetRootElement();
  const char* type = root ? root->GetAttribute("type") : nullptr;
  vtkXMLDataElement* collection = root ? root->FindNestedElementWithName("Collection") : nullptr;
  if (!type || std::string(type) != "Collection" || !collection)
    throw VtkError(pvd_file.string() + ": not a VTK collection (VTKFile type=\"Collection\")");
  std::vector<CollectionEntry> out;
  for (int k = 0; k < collection->GetNumberOfNestedElements(); ++k) {
    vtkXMLDataElement* e = collection->GetNestedElement(k);
    const char* time = e->GetAttribute("timestep");
    const char* file = e->GetAttribute("file");
    if (!time || !file) throw VtkError(pvd_file.string() + ": DataSet entry " + std::to_string(k) + " lacks timestep or file");
    char* end = nullptr;
    const double t = std::strtod(time, &end);
    if (end == time || *end != '\0' || !std::isfinite(t))
      throw VtkError(pvd_file.string() + ": DataSet entry " + std::to_string(k) + ": timestep '" + time + "' is not a number");
    out.push_back({t, pvd_file.parent_path() / file});
  }
  return out;
}

}  // namespace demfem::vtkio
