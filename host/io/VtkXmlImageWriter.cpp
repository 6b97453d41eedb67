// VTK XML ImageData (.vti) writer: one point array, appended raw data in zlib blocks, NIfTI orientation as Direction.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/VtkXmlArrays.hpp"

#include <cmath>
#include <sstream>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

std::string_view vtkTypeName(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return "UInt8";
    case ScalarType::UInt16:
        return "UInt16";
    case ScalarType::Int16:
        return "Int16";
    case ScalarType::Float32:
        return "Float32";
    case ScalarType::Float64:
        return "Float64";
    }
    return "Float32";
}

// Origin, Spacing and Direction (row-major 3x3, unit columns) of the image in world coordinates.
struct ImageGeometry {
    std::array<double, 3> origin{}, spacing{};
    std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
};

ImageGeometry geometry(const Volume& volume, const WriteOptions& options) {
    ImageGeometry g;
    g.origin = volume.origin;
    g.spacing = volume.spacing;
    g.direction = volume.direction; // the model's origin and direction are world (RAS when anatomical)
    if (!options.nifti) return g;
    // The NIfTI voxel-to-world transform split into VTK's origin, spacing and direction columns.
    const auto a = niftiVoxelToWorld(niftiMetadataOnGrid(*options.nifti, volume));
    for (int col = 0; col < 3; ++col) {
        const double n = std::hypot(a[0][col], a[1][col], a[2][col]);
        if (!(n > 0) || !std::isfinite(n)) return g; // a degenerate transform: keep the axis-aligned grid
        g.spacing[col] = n;
        for (int row = 0; row < 3; ++row)
            g.direction[3 * row + col] = a[row][col] / n;
    }
    for (int row = 0; row < 3; ++row)
        g.origin[row] = a[row][3];
    return g;
}

std::string joined(std::span<const double> values) {
    std::string s;
    for (double v : values) {
        if (!s.empty()) s += ' ';
        s += formatDouble(v);
    }
    return s;
}

// The point array `payload` (components per point, interleaved) on the grid of `volume`.
void writeImageData(const Volume& volume, const Volume& payload, std::size_t components, const fs::path& path,
                    const WriteOptions& options) {
    const VtkXmlEncodedArray encoded =
        encodeVtkXmlArray(bytesInOrder(payload, Endian::Little), options.compress);
    const ImageGeometry g = geometry(volume, options);
    const std::string extent = "0 " + std::to_string(volume.dims().x - 1) + " 0 " +
                               std::to_string(volume.dims().y - 1) + " 0 " +
                               std::to_string(volume.dims().z - 1);
    std::ostringstream x;
    x << "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\""
      << (options.compress ? " compressor=\"vtkZLibDataCompressor\"" : "") << ">\n"
      << "  <ImageData WholeExtent=\"" << extent << "\" Origin=\"" << joined(g.origin) << "\" Spacing=\""
      << joined(g.spacing) << "\" Direction=\"" << joined(g.direction) << "\">\n"
      << "    <Piece Extent=\"" << extent << "\">\n"
      << "      <PointData Scalars=\"scalars\">\n"
      << "        <DataArray type=\"" << vtkTypeName(volume.type()) << "\" Name=\"scalars\""
      << (components > 1 ? " NumberOfComponents=\"" + std::to_string(components) + "\"" : std::string())
      << " format=\"appended\" offset=\"0\"/>\n"
      << "      </PointData>\n      <CellData>\n      </CellData>\n    </Piece>\n  </ImageData>\n"
      << "  <AppendedData encoding=\"raw\">\n   _";
    AtomicFile out(path);
    out.write(x.str());
    out.write(encoded.header);
    out.write(encoded.data);
    out.write("\n  </AppendedData>\n</VTKFile>\n");
    out.commit();
}

} // namespace

void writeVtkXmlImage(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    writeImageData(volume, volume, 1, path, options);
}

void writeVtkXmlChannels(const ChannelVolume& channels, const fs::path& path, const WriteOptions& options) {
    writeImageData(channels.channels.front(), interleaveChannels(channels.channels), channels.count(), path,
                   options);
}

} // namespace volcl::io
