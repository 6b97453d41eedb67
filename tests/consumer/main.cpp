// Uses the installed volcl: builds a phantom on the default device and checks it against the reference.
#include "host/Volume.hpp"
#include "host/phantoms/Phantoms.hpp"
#include "host/runtime/ClRuntime.hpp"

#include <cmath>
#include <cstdio>

int main() {
    volcl::ComputeContext cc;
    volcl::Volume v = volcl::generateMarschnerLobb(cc, {9, 9, 9});
    volcl::Volume r = volcl::marschnerLobbReference({9, 9, 9});
    double err = 0;
    for (std::size_t i = 0; i < v.voxelCount(); ++i) err = std::fmax(err, std::fabs(v.valueAt(i) - r.valueAt(i)));
    std::printf("consumer: %s, max error %.3g\n", cc.device().name.c_str(), err);
    return err <= 1e-5 ? 0 : 1;
}
