// NIfTI-1 metadata: voxel-to-world transforms, re-anchoring on a cropped or downsampled grid, text form.
#include "host/io/NiftiMetadata.hpp"

#include "core/Error.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

namespace {

using Affine = std::array<std::array<double, 4>, 3>;

// Rotation of the qform quaternion (b, c, d; a from the unit norm), as nifti1.h defines it.
std::array<std::array<double, 3>, 3> qformRotation(const NiftiMetadata& m) {
    const double b = m.quaternB, c = m.quaternC, d = m.quaternD;
    const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
    return {{{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
             {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
             {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}}};
}

Affine qformAffine(const NiftiMetadata& m) {
    const auto r = qformRotation(m);
    const std::array<double, 3> scale{m.spacing[0], m.spacing[1], m.spacing[2] * (m.qfac < 0 ? -1.0 : 1.0)};
    Affine a{};
    for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col)
            a[row][col] = r[row][col] * scale[col];
        a[row][3] = m.qoffset[row];
    }
    return a;
}

Affine sformAffine(const NiftiMetadata& m) {
    Affine a{};
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 4; ++col)
            a[row][col] = m.srow[row][col];
    return a;
}

// World position of source index `index` under `a`.
std::array<double, 3> worldOf(const Affine& a, const std::array<double, 3>& index) {
    std::array<double, 3> p{};
    for (int row = 0; row < 3; ++row)
        p[row] = a[row][0] * index[0] + a[row][1] * index[1] + a[row][2] * index[2] + a[row][3];
    return p;
}

float requireFloat(const nlohmann::json& j, const char* key, const std::string& name) {
    const double v = j.at(key).get<double>();
    if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max())
        throw IoError(name + ": NIfTI metadata: " + key + " is not a finite float");
    return static_cast<float>(v);
}

template <std::size_t N>
std::array<float, N> requireFloats(const nlohmann::json& j, const char* key, const std::string& name) {
    const nlohmann::json& a = j.at(key);
    if (!a.is_array() || a.size() != N)
        throw IoError(name + ": NIfTI metadata: " + key + " must hold " + std::to_string(N) + " numbers");
    std::array<float, N> out{};
    for (std::size_t i = 0; i < N; ++i) {
        const nlohmann::json one{{"v", a[i]}};
        out[i] = requireFloat(one, "v", name);
    }
    return out;
}

template <class Int> Int requireInt(const nlohmann::json& j, const char* key, const std::string& name) {
    const long long v = j.at(key).get<long long>();
    if (v < std::numeric_limits<Int>::min() || v > std::numeric_limits<Int>::max())
        throw IoError(name + ": NIfTI metadata: " + key + " " + std::to_string(v) + " is out of range");
    return static_cast<Int>(v);
}

std::string requireText(const nlohmann::json& j, const char* key, std::size_t maxSize,
                        const std::string& name) {
    std::string s = j.at(key).get<std::string>();
    if (s.size() > maxSize || s.find('\0') != std::string::npos)
        throw IoError(name + ": NIfTI metadata: " + key + " is longer than " + std::to_string(maxSize) +
                      " characters");
    return s;
}

} // namespace

bool niftiStoredValuesExact(const NiftiMetadata& m) noexcept {
    // NIfTI codes 2 (uint8), 4 (int16) and 512 (uint16): the model's integer types.
    return m.scales() && (m.datatype == 2 || m.datatype == 4 || m.datatype == 512);
}

Volume niftiDataUnits(const Volume& stored, const NiftiMetadata& m) {
    if (!m.scales()) return stored;
    const double slope = m.sclSlope, inter = m.sclInter;
    Volume f(stored.dims(), ScalarType::Float32);
    f.spacing = stored.spacing;
    f.origin = stored.origin;
    f.direction = stored.direction;
    f.anatomical = stored.anatomical;
    auto out = f.values<float>();
    for (std::size_t i = 0; i < out.size(); ++i)
        out[i] = static_cast<float>(stored.valueAt(i) * slope + inter);
    return f;
}

Affine niftiVoxelToWorld(const NiftiMetadata& m) {
    if (m.sformCode > 0) return sformAffine(m);
    if (m.qformCode > 0) return qformAffine(m);
    Affine a{};
    for (int i = 0; i < 3; ++i) {
        a[i][i] = m.spacing[i];
        a[i][3] = m.origin[i];
    }
    return a;
}

Direction3 niftiDirection(const NiftiMetadata& m) {
    auto oriented = [](const Affine& a) {
        Direction3 d{};
        for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col)
                d[std::size_t(3 * row + col)] = a[row][col];
        return orthonormalDirection(d);
    };
    // A singular sform falls back to the qform, as nibabel's get_best_affine does for an unusable one.
    if (m.sformCode > 0) try {
            return oriented(sformAffine(m));
        } catch (const DataError&) {
        }
    if (m.qformCode > 0) try {
            return oriented(qformAffine(m));
        } catch (const DataError&) {
        }
    return kIdentityDirection;
}

NiftiMetadata niftiMetadataOnGrid(const NiftiMetadata& source, const Volume& volume) {
    // Source index of the volume's voxel (i, j, k) is first + i*ratio per axis, in the model's terms: the
    // model places voxel 0 of a crop at origin + D diag(spacing) first, so first = D^T (moved origin) /
    // spacing (D = identity for volumes without a direction).
    std::array<double, 3> ratio{}, first{};
    bool same = true;
    for (int a = 0; a < 3; ++a) {
        ratio[a] = volume.spacing[a] / source.spacing[a];
        double along = 0.0;
        for (int r = 0; r < 3; ++r)
            along += volume.direction[std::size_t(r * 3 + a)] * (volume.origin[r] - source.origin[r]);
        first[a] = along / source.spacing[a];
        same = same && std::abs(ratio[a] - 1) < 1e-9 && std::abs(first[a]) < 1e-6;
    }
    NiftiMetadata m = source;
    if (same) return m;
    m.spacing = volume.spacing;
    m.origin = volume.origin;
    for (int a = 0; a < 3; ++a)
        m.pixdim[a] = static_cast<float>(volume.spacing[a]);
    const std::array<double, 3> q = worldOf(qformAffine(source), first);
    for (int row = 0; row < 3; ++row) {
        m.qoffset[row] = static_cast<float>(q[row]);
        for (int col = 0; col < 3; ++col)
            m.srow[row][col] = static_cast<float>(source.srow[row][col] * ratio[col]);
    }
    const std::array<double, 3> s = worldOf(sformAffine(source), first);
    for (int row = 0; row < 3; ++row)
        m.srow[row][3] = static_cast<float>(s[row]);
    return m;
}

NiftiMetadata niftiMetadataForVolume(const Volume& volume) {
    NiftiMetadata m;
    m.spacing = volume.spacing;
    m.origin = volume.origin;
    m.qformCode = 1;
    m.sformCode = 1;
    const Direction3& d = volume.direction;
    for (int a = 0; a < 3; ++a) {
        m.pixdim[a] = static_cast<float>(volume.spacing[a]);
        m.qoffset[a] = static_cast<float>(volume.origin[a]);
        for (int col = 0; col < 3; ++col)
            m.srow[a][col] = static_cast<float>(d[std::size_t(3 * a + col)] * volume.spacing[col]);
        m.srow[a][3] = static_cast<float>(volume.origin[a]);
    }
    // The qform's quaternion (nifti1_io's mat44_to_quatern): a mirroring direction is qfac -1 with the
    // third column negated.
    double r[3][3];
    const bool mirrored = determinant(d) < 0;
    m.qfac = mirrored ? -1.0f : 1.0f;
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 3; ++col)
            r[row][col] = d[std::size_t(3 * row + col)] * (col == 2 && mirrored ? -1.0 : 1.0);
    double qa = r[0][0] + r[1][1] + r[2][2] + 1.0, qb = 0, qc = 0, qd = 0;
    if (qa > 0.5) {
        qa = 0.5 * std::sqrt(qa);
        qb = 0.25 * (r[2][1] - r[1][2]) / qa;
        qc = 0.25 * (r[0][2] - r[2][0]) / qa;
        qd = 0.25 * (r[1][0] - r[0][1]) / qa;
    } else {
        const double xd = 1.0 + r[0][0] - (r[1][1] + r[2][2]), yd = 1.0 + r[1][1] - (r[0][0] + r[2][2]),
                     zd = 1.0 + r[2][2] - (r[0][0] + r[1][1]);
        if (xd > 1.0) {
            qb = 0.5 * std::sqrt(xd);
            qc = 0.25 * (r[0][1] + r[1][0]) / qb;
            qd = 0.25 * (r[0][2] + r[2][0]) / qb;
            qa = 0.25 * (r[2][1] - r[1][2]) / qb;
        } else if (yd > 1.0) {
            qc = 0.5 * std::sqrt(yd);
            qb = 0.25 * (r[0][1] + r[1][0]) / qc;
            qd = 0.25 * (r[1][2] + r[2][1]) / qc;
            qa = 0.25 * (r[0][2] - r[2][0]) / qc;
        } else {
            qd = 0.5 * std::sqrt(zd);
            qb = 0.25 * (r[0][2] + r[2][0]) / qd;
            qc = 0.25 * (r[1][2] + r[2][1]) / qd;
            qa = 0.25 * (r[1][0] - r[0][1]) / qd;
        }
        if (qa < 0.0) {
            qb = -qb;
            qc = -qc;
            qd = -qd;
        }
    }
    m.quaternB = static_cast<float>(qb);
    m.quaternC = static_cast<float>(qc);
    m.quaternD = static_cast<float>(qd);
    return m;
}

std::string niftiMetadataToText(const NiftiMetadata& m) {
    nlohmann::json j;
    j["spacing"] = m.spacing;
    j["origin"] = m.origin;
    j["datatype"] = m.datatype;
    j["qform_code"] = m.qformCode;
    j["sform_code"] = m.sformCode;
    j["quatern"] = {m.quaternB, m.quaternC, m.quaternD};
    j["qfac"] = m.qfac;
    j["qoffset"] = m.qoffset;
    j["pixdim"] = m.pixdim;
    j["srow"] = {m.srow[0], m.srow[1], m.srow[2]};
    j["xyzt_units"] = m.xyztUnits;
    j["time_step"] = m.timeStep;
    j["toffset"] = m.toffset;
    j["intent_code"] = m.intentCode;
    j["intent_p"] = m.intentP;
    j["intent_name"] = m.intentName;
    j["scl_slope"] = m.sclSlope;
    j["scl_inter"] = m.sclInter;
    j["cal_min"] = m.calMin;
    j["cal_max"] = m.calMax;
    j["descrip"] = m.descrip;
    return j.dump();
}

NiftiMetadata niftiMetadataFromText(std::string_view text, const std::string& name) {
    NiftiMetadata m;
    try {
        const nlohmann::json j = nlohmann::json::parse(text);
        if (!j.is_object()) throw IoError(name + ": NIfTI metadata is not a JSON object");
        for (int a = 0; a < 3; ++a) {
            m.spacing[a] = j.at("spacing")[a].get<double>();
            m.origin[a] = j.at("origin")[a].get<double>();
            if (!(m.spacing[a] > 0) || !std::isfinite(m.spacing[a]) || !std::isfinite(m.origin[a]))
                throw IoError(name + ": NIfTI metadata: spacing and origin must be finite, spacing positive");
        }
        m.datatype = requireInt<std::int16_t>(j, "datatype", name);
        m.qformCode = requireInt<std::int16_t>(j, "qform_code", name);
        m.sformCode = requireInt<std::int16_t>(j, "sform_code", name);
        const auto quatern = requireFloats<3>(j, "quatern", name);
        m.quaternB = quatern[0];
        m.quaternC = quatern[1];
        m.quaternD = quatern[2];
        m.qfac = requireFloat(j, "qfac", name) < 0 ? -1.0f : 1.0f;
        m.qoffset = requireFloats<3>(j, "qoffset", name);
        m.pixdim = requireFloats<3>(j, "pixdim", name);
        const nlohmann::json& srow = j.at("srow");
        if (!srow.is_array() || srow.size() != 3)
            throw IoError(name + ": NIfTI metadata: srow must hold 3 rows");
        for (int row = 0; row < 3; ++row) {
            const nlohmann::json one{{"row", srow[row]}};
            m.srow[row] = requireFloats<4>(one, "row", name);
        }
        m.xyztUnits = requireInt<std::uint8_t>(j, "xyzt_units", name);
        m.timeStep = requireFloat(j, "time_step", name);
        m.toffset = requireFloat(j, "toffset", name);
        m.intentCode = requireInt<std::int16_t>(j, "intent_code", name);
        m.intentP = requireFloats<3>(j, "intent_p", name);
        m.intentName = requireText(j, "intent_name", 15, name);
        m.sclSlope = requireFloat(j, "scl_slope", name);
        m.sclInter = requireFloat(j, "scl_inter", name);
        m.calMin = requireFloat(j, "cal_min", name);
        m.calMax = requireFloat(j, "cal_max", name);
        m.descrip = requireText(j, "descrip", 79, name);
    } catch (const nlohmann::json::exception& e) {
        throw IoError(name + ": NIfTI metadata is malformed (" + std::string(e.what()) + ")");
    }
    return m;
}

std::optional<VczNifti> niftiFromVczMetadata(const std::map<std::string, std::string>& metadata,
                                             const std::string& name) {
    const auto fields = metadata.find(std::string(kVczNiftiMetadataKey));
    const auto values = metadata.find(std::string(kVczNiftiValuesKey));
    if (values != metadata.end() && (values->second != "stored" || fields == metadata.end()))
        throw IoError(name + ": metadata " + std::string(kVczNiftiValuesKey) + " '" + values->second +
                      "' is not 'stored' with a NIfTI header");
    if (fields == metadata.end()) return std::nullopt;
    VczNifti n{niftiMetadataFromText(fields->second, name), false};
    n.storedValues = values != metadata.end() && n.meta.scales();
    return n;
}

} // namespace volcl
