// 3D lifting wavelet transforms (wavelet/transform/LiftingTransform.hpp), under their public include path.
#pragma once

#include "wavelet/transform/LiftingTransform.hpp"
