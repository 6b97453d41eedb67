// Exception hierarchy used across volcl; the CLI maps each kind to an exit code in one place.
#pragma once

#include <stdexcept>
#include <string>

namespace volcl {

/// Base of every error volcl throws. `what()` is one line meant for a user.
/// Example: `try { readVolumeFile(p); } catch (const volcl::Error& e) { std::cerr << e.what(); }`
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Wrong command-line or API usage (bad flag combination, invalid argument value). CLI exit code 2.
class UsageError : public Error {
public:
    using Error::Error;
};

/// A file could not be opened, read or written, or its content is malformed, truncated or corrupted.
class IoError : public Error {
public:
    using Error::Error;
};

/// Input that is well-formed but unsupported or numerically invalid (NaN in a volume, non-scalar grid...).
class DataError : public Error {
public:
    using Error::Error;
};

/// An OpenCL call failed. Carries the failing call, the error code and, for builds, the build log.
class ClError : public Error {
public:
    ClError(std::string call, int code, std::string buildLog = {});
    const std::string& call() const noexcept { return call_; }
    int code() const noexcept { return code_; }
    const std::string& buildLog() const noexcept { return buildLog_; }

private:
    std::string call_;
    int code_;
    std::string buildLog_;
};

/// Name of an OpenCL error code, e.g. "CL_OUT_OF_RESOURCES".
const char* clErrorName(int code) noexcept;

} // namespace volcl
