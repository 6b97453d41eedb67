// The fog's kernel parameters and height-map buffer, cached across rebuilds.
#include "render/FogDevice.hpp"

#include "render/FogModel.hpp"

#include <ios>
#include <sstream>

namespace volcl {
namespace {

/// Everything that decides the map's texels and placement, exactly (hexadecimal floats).
std::string mapKey(const FogEffect& f, const WorldBox& volumeBox) {
    std::ostringstream k;
    k << std::hexfloat << f.heightMap.string();
    if (f.heightRange) k << '|' << (*f.heightRange)[0] << ',' << (*f.heightRange)[1];
    const WorldBox box = f.box ? *f.box : volumeBox;
    for (int a = 0; a < 3; ++a)
        k << '|' << box.origin[a] << ',' << box.extent[a] << ',' << f.up[a];
    return k.str();
}

} // namespace

VolclFogParams FogDevice::update(ComputeContext& cc, const FogEffect& fog, const WorldBox& volumeBox,
                                 bool withMap) {
    if (withMap) {
        const std::string key = mapKey(fog, volumeBox);
        if (key != key_) {
            const FogField field(fog, volumeBox);
            map_ = cc.upload(field.mapTexels(), CL_MEM_READ_ONLY);
            const VolclFogParams p = field.params();
            for (int i = 0; i < 2; ++i) {
                axes_[i] = p.mapAxis[i];
                size_[i] = p.mapSize[i];
            }
            key_ = key;
        }
    }
    // The map's axes and size are all params() takes from it: resolve the rest without reading the image.
    FogEffect noMap = fog;
    noMap.heightMap.clear();
    VolclFogParams p = FogField(noMap, volumeBox).params();
    if (withMap)
        for (int i = 0; i < 2; ++i) {
            p.mapAxis[i] = axes_[i];
            p.mapSize[i] = size_[i];
        }
    return p;
}

const DeviceBuffer<float>& FogDevice::buffer(ComputeContext& cc) {
    if (map_.size() == 0) map_ = cc.allocate<float>(1, CL_MEM_READ_ONLY);
    return map_;
}

} // namespace volcl
