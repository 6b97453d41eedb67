// The .vcz container's header, frame table and brick index (wavelet/container/VczFormat.hpp), under its
// public include path.
#pragma once

#include "wavelet/container/VczFormat.hpp"
