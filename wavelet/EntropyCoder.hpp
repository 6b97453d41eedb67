// Entropy coding of wavelet coefficient sections (internal to the codec): the section coder's interface
// and its test switches, under the path that tests and benchmarks include.
#pragma once

#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/TestSwitches.hpp"
