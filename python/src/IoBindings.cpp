// Volume files for Python: read (every reader the command line has, .vcz included) and write.
#include "python/src/Bindings.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/Series.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"

#include <nanobind/stl/array.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <cctype>

namespace volcl::python {
namespace {

bool hasVczExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".vcz";
}

// Every frame of `path` with its grid: {"frames": [a[z, y, x], ...], "spacing", "origin", "times", "format"}.
nb::dict readFile(const std::string& path, Context* context) {
    TimeSeries series;
    std::string format;
    {
        nb::gil_scoped_release released;
        if (hasVczExtension(path)) {
            if (!context) throw UsageError(path + ": reading a .vcz needs a device context");
            const VczReader reader(readFileBytes(path), path);
            // A scaled NIfTI's stored integers come back in data units, as volcl.read of the .nii gives them.
            const auto nifti = niftiFromVczMetadata(reader.header().metadata, path);
            std::lock_guard lock(context->mutex);
            // Each frame decoded once: P/B frames predict from the frames already decoded.
            decodeEachFrame(reader, context->cc, 2, nullptr, [&](std::size_t f, Volume&& v) {
                if (nifti) { // the source header travels in the file: oriented as the .nii is
                    v.direction = niftiDirection(nifti->meta);
                    v.anatomical = true;
                }
                series.frames.push_back(nifti && nifti->storedValues ? niftiDataUnits(v, nifti->meta)
                                                                     : std::move(v));
                series.times.push_back(reader.header().frames[f].time);
            });
            format = "vcz";
        } else {
            const std::string inputs[] = {path};
            SeriesInput in = readSeriesInputs(inputs);
            format = std::string(volumeFormatName(detectVolumeFormat(in.sources.front().file)));
            series = std::move(in.series);
        }
    }
    nb::dict out;
    out["spacing"] = series.frames.front().spacing;
    out["origin"] = series.frames.front().origin;
    out["direction"] = series.frames.front().direction;
    out["anatomical"] = series.frames.front().anatomical;
    out["times"] = series.times;
    out["format"] = format;
    nb::list frames;
    for (Volume& v : series.frames)
        frames.append(volumeToArray(std::move(v)));
    out["frames"] = frames;
    return out;
}

void writeFile(const std::string& path, const InputArray& array, const std::array<double, 3>& spacing,
               const std::array<double, 3>& origin, bool compress) {
    const Volume v = arrayToVolume(array, spacing, origin);
    nb::gil_scoped_release released;
    WriteOptions options;
    options.compress = compress;
    writeVolumeFile(v, path, options);
}

// An image file as float32 [height, width, channels] and its channel names (EXR keeps every channel).
std::tuple<nb::object, std::vector<std::string>> readImageFile(const std::string& path) {
    ImageBuffer image;
    {
        nb::gil_scoped_release released;
        image = readImage(path);
    }
    std::vector<std::string> channels = image.channels;
    return {imageToArray(std::move(image)), channels};
}

} // namespace

void bindIo(nb::module_& m) {
    m.def("read", &readFile, nb::arg("path"), nb::arg("context").none(),
          "Every frame of a volume file (any reader of the command line; .vcz needs a context).");
    m.def("write", &writeFile, nb::arg("path"), nb::arg("array"), nb::arg("spacing"), nb::arg("origin"),
          nb::arg("compress") = true, "Writes one volume; the format follows the extension. Atomic.");
    m.def("read_image", &readImageFile, nb::arg("path"),
          "An image (EXR, PNG, ...) as float32 pixels + channel names.");
}

} // namespace volcl::python
