// Command-line flags that build or override a Scene (see SceneFlags.hpp).
#include "apps/cli/SceneFlags.hpp"

#include "core/AtomicFile.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "meshcodec/MeshCodec.hpp"
#include "wavelet/Codec.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/Volume.hpp"
#include "render/CameraFraming.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <sstream>
#include <stdexcept>

namespace volcl::cli {

std::vector<double> parseNumbers(const std::string& text, std::size_t count, const std::string& what) {
    std::vector<double> out;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        try {
            std::size_t used = 0;
            out.push_back(std::stod(item, &used));
            if (used != item.size()) throw std::invalid_argument(item);
        } catch (const std::exception&) {
            throw UsageError(what + ": '" + item + "' is not a number");
        }
    }
    if (count && out.size() != count)
        throw UsageError(what + ": expected " + std::to_string(count) + " comma-separated numbers, got '" +
                         text + "'");
    return out;
}

Vec3 parseVec3(const std::string& text, const std::string& what) {
    const auto v = parseNumbers(text, 3, what);
    return {v[0], v[1], v[2]};
}

void SceneFlags::add(CLI::App* cmd) {
    const Scene d; // the defaults a scene without the field gets, shown in --help
    auto num = [](double v) {
        std::ostringstream os;
        os << v;
        return os.str();
    };
    cmd->add_option("--scene", scene, "Scene JSON (see docs/rendering.md); flags below override its fields");
    cmd->add_option("--volume", volume, "Volume file (overrides the scene's)");
    std::string presets;
    for (const auto& n : TransferFunction::builtinPresetNames())
        presets += (presets.empty() ? "" : ", ") + n;
    cmd->add_option("--tf", tf,
                    "Transfer function: canonical/ParaView JSON, an RGBA strip image, or preset:NAME (" +
                        presets +
                        "; default: ParaView's, a grey ramp with opacity 0 to 1 over the data range)");
    cmd->add_option("--tf-range", tfRange,
                    "Data range LO,HI the transfer function is spread over (default: presets and other maps "
                    "spanning exactly [0,1] take the data range, maps in data values stay as authored)");
    cmd->add_option("--tf-unit-distance", tfUnitDistance,
                    "ParaView opacity unit distance in world units, or 'auto' (ParaView's default: box "
                    "diagonal / cube root of the cell count)")
        ->capture_default_str();
    cmd->add_option("--frame", frame, "Frame K (0-based) of a time series input")->default_str("0");
    cmd->add_option("--mode", mode, "dvr, mip, iso, xray or emission (emission only, no absorption)")
        ->default_str(std::string(renderModeName(d.mode)));
    cmd->add_option("--step", step,
                    "Sampling distance: D in world units, or Nvox in voxels of the finest spacing (a mesh: "
                    "of its approximate cell length)")
        ->default_str(num(kDefaultStepVoxels) + "vox");
    cmd->add_option("--preintegration", preint, "none, 2d or 3d (dvr only)")
        ->default_str(std::string(preintegrationName(d.preintegration)));
    cmd->add_option("--filter", filter,
                    "Reconstruction of samples and gradients: linear (trilinear, finite differences), cubic "
                    "(interpolating cubic B-spline), bspline (approximating cubic B-spline); --smoothing 1 "
                    "removes the "
                    "terraces of 8-bit iso-surfaces with any of them")
        ->default_str(std::string(filterName(d.filter)));
    cmd->add_option(
           "--smoothing", smoothing,
           "Gaussian sigma in voxels applied to the data before the filter reads it (0-8; 1 removes the "
           "terraces of 8-bit iso-surfaces)")
        ->default_str(num(d.smoothing));
    cmd->add_option("--window", window, "MIP window centre,width in data values (default: the data range)");
    cmd->add_option("--mip-color", mipColor,
                    "MIP colour: grey (windowed grey), tf (transfer-function colour, windowed brightness), "
                    "tf-opacity (the transfer function's colour and opacity)")
        ->default_str(std::string(mipColorName(d.mipColor)));
    cmd->add_option("--width", width, "Image width in pixels")->default_str(num(d.width));
    cmd->add_option("--height", height, "Image height in pixels")->default_str(num(d.height));
    cmd->add_option("--view", view,
                    "Named view of the volume's box in the data's axes (+z up, +y toward the viewer in "
                    "front): front, back, left, right, top, bottom, iso (default: front for NIfTI/NRRD, "
                    "else looking along +z)");
    cmd->add_option("--orbit", orbit,
                    "Azimuth,elevation in degrees from the front view (azimuth toward +x, elevation toward "
                    "+z); the box is framed as by --view");
    cmd->add_option("--projection", projection, "orthographic or perspective")->default_str("orthographic");
    cmd->add_option("--eye", eye, "Camera position x,y,z (default: framed from --view)");
    cmd->add_option("--target", target, "Camera target x,y,z (default: the centre of the volume's box)");
    cmd->add_option("--up", up, "Camera up vector x,y,z (default: from the view)");
    cmd->add_option("--view-height", viewHeight,
                    "Orthographic view height in world units (default: fitted to show the whole box)");
    cmd->add_option("--fov", fov, "Perspective vertical field of view in degrees")
        ->default_str(num(Camera{}.fovYDeg));
    cmd->add_option("--background", background, "PNG background r,g,b,a (straight, linear)")
        ->default_str("0,0,0,1");
    cmd->add_option("--nan-color", nanColor,
                    "Colour of NaN/Inf samples r,g,b,a (straight; a: opacity per unit distance as a TF's)")
        ->default_str("0,0,0,0");
    cmd->add_option("--lod", lod,
                    "Compressed (.vcz) inputs: full (level 0 everywhere) or auto (a level per brick from its "
                    "estimated screen-space error)")
        ->default_str(std::string(lodModeName(d.lod)));
    cmd->add_option("--lod-error", lodError,
                    "Compressed inputs, --lod auto: largest estimated error per brick")
        ->default_str(num(d.lodError));
    cmd->add_option("--cache-mb", cacheMb, "Compressed inputs: budget of the decoded-brick cache in MB")
        ->default_str(num(d.cacheMb));
    cmd->add_option("--refine-bricks", refineBricks,
                    "view of a .vcz with --lod auto: missing bricks decoded per frame while the view refines "
                    "(default: 16, and more while their decode fits the last frame's kernel time)");
    cmd->add_option("--early-termination", earlyTermination, "Stop rays at this opacity (1 = never)")
        ->default_str(num(d.earlyTermination));
    cmd->add_flag("--no-skipping", noSkipping, "Disable empty-space skipping (as --skipping off)");
    cmd->add_option("--skipping", skipping,
                    "Empty-space skipping: auto (measured per volume and TF on a probe frame), on, off")
        ->default_str(std::string(skipModeName(d.skipping)));
    cmd->add_option("--table-size", tableSize, "Pre-integration table nodes")->default_str(num(d.tableSize));
    cmd->add_option("--table-lengths", tableLengths, "3D pre-integration: number of lengths")
        ->default_str(num(d.tableLengths));
    cmd->add_option("--iso", isos, "Iso-surface value[:r,g,b,a] (repeatable)");
    cmd->add_option(
        "--light", lights,
        "Light: head | dir:x,y,z | point:x,y,z, optionally @intensity (repeatable; default: a head "
        "light when shading needs one)");
    // A switch: `--shading` alone shades with the default coefficients, `--shading=A,D,S,N` (or
    // `--shading A,D,S,N`) gives them; a following flag is never taken as its value.
    shadingOption = cmd->add_option("--shading", shading,
                                    "Blinn-Phong shading; optional =ambient,diffuse,specular,shininess "
                                    "(iso mode: on by default)")
                        ->expected(0, 1)
                        ->default_str(num(d.effects.ambient) + "," + num(d.effects.diffuse) + "," +
                                      num(d.effects.specular) + "," + num(d.effects.shininess));
    cmd->add_flag("--no-shading", noShading, "Do not shade (iso mode shades by default)");
    cmd->add_flag("--sobel", sobel, "Sobel gradients (same as --gradient sobel)");
    cmd->add_option("--gradient", gradient,
                    "Shading gradients: cache (default: precomputed per volume, trilinear), cache-nearest, "
                    "central, sobel");
    cmd->add_flag("--shadows", shadows, "Shadows toward each light (--shadow-method)");
    cmd->add_option("--shadow-step", shadowStep,
                    "Shadow integration step in world units (0 = the render step)")
        ->default_str(num(d.effects.shadowStep));
    cmd->add_option("--shadow-method", shadowMethod,
                    "volume (a light-attenuation volume per light, one fetch per sample) or rays (a "
                    "secondary ray per sample, exact)")
        ->check(CLI::IsMember({"volume", "rays"}))
        ->default_str("volume");
    cmd->add_option("--light-volume-cell", lightVolumeCell, "Voxels per light-volume cell edge (1..64)")
        ->default_str(num(d.effects.lightVolumeCell));
    cmd->add_option("--scattering", scattering, "Scattering albedo,g (Henyey-Greenstein)");
    cmd->add_option("--scattering-order", scatteringOrder, "single (ray marcher) or multiple (path tracer)")
        ->check(CLI::IsMember({"single", "multiple"}));
    cmd->add_option("--samples", samples, "Path-tracer samples per pixel (multiple scattering)");
    cmd->add_option(
        "--clip", clips,
        "Clipping plane nx,ny,nz,offset keeping n.x + offset >= 0 (repeatable; at most 8 planes, a "
        "crop box counting 6)");
    cmd->add_option(
        "--crop-box", cropBox,
        "Cropping box x0,y0,z0:x1,y1,z1 in world units (the frame of --clip and --eye), or with a vox "
        "suffix in voxel indices (x0,y0,z0:x1,y1,z1vox); its six faces count as clip planes");
    cmd->add_option("--labels", labels,
                    "Label map (uint8/uint16/int16 volume) drawn with the volume, looked up in world "
                    "coordinates (docs/labels.md)");
    cmd->add_option("--label-table", labelTable,
                    "Label table: JSON, Slicer .ctbl/.txt, ITK-SNAP, FSL/mricron .txt or mricron .lut "
                    "(default: a categorical palette, label 0 unlabelled)");
    cmd->add_option("--label-mode", labelMode,
                    "replace (label colour and opacity inside visible labels), modulate (TF opacity x label "
                    "opacity, TF colour x label colour) or alone (the labels only)")
        ->check(CLI::IsMember({"replace", "modulate", "alone"}));
    cmd->add_option("--label-boundary", labelBoundary,
                    "smooth (labels weighted by their trilinear indicator) or nearest (the nearest voxel's "
                    "label: staircase boundaries)")
        ->check(CLI::IsMember({"smooth", "nearest"}));
    cmd->add_option(
           "--method", method,
           "Grids: raymarch, shear-warp (orthographic preview) or drc (discrete ray casting preview); "
           "meshes: cells (exact cell traversal), kbuffer (sorted faces, k-buffer) or pt (projected "
           "tetrahedra in visibility order)")
        ->default_str("raymarch (grids), " + std::string(meshMethodName(d.meshMethod)) + " (meshes)");
    cmd->add_option("--k", k, "Meshes, method kbuffer: k-buffer entries per pixel (2..8)")
        ->default_str(num(d.kBufferDepth));
    cmd->add_option(
           "--sort", sort,
           "Meshes, methods pt and kbuffer: cell order centroid (fast, approximate; kbuffer: faces sorted "
           "by centroid), mpvo (exact on convex meshes) or convexified (MPVO over the mesh and cells filling "
           "its concavities); kbuffer places each face by the cell order")
        ->default_str(
            "mpvo if the mesh is convex, else convexified; kbuffer: centroid where tets may overlap");
    raw.add(*cmd);
    mesh.add(*cmd);
}

Scene SceneFlags::build() const {
    Scene s = scene.empty() ? Scene{} : Scene::fromFile(scene);
    if (scene.empty()) s.stepVoxels = kDefaultStepVoxels; // as a scene file without a step
    if (!volume.empty()) s.volume = volume;
    if (!tf.empty()) s.tf = tf;
    if (!mode.empty()) s.mode = parseRenderMode(mode);
    if (!step.empty()) {
        const StepSpec st = parseStepSpec(step, "--step");
        s.stepVoxels.reset();
        (st.voxels ? s.stepVoxels.emplace() : s.step) = st.value;
    }
    if (!preint.empty()) s.preintegration = parsePreintegration(preint);
    if (width) s.width = *width;
    if (height) s.height = *height;
    if (!filter.empty()) s.filter = parseFilter(filter);
    if (smoothing) s.smoothing = *smoothing;
    if (!window.empty()) {
        const auto w = parseNumbers(window, 2, "--window");
        s.window = std::array<double, 2>{w[0], w[1]};
    }
    if (!mipColor.empty()) s.mipColor = parseMipColor(mipColor);
    if (!method.empty()) parseRenderMethod(method, "--method", s);
    if (k) s.kBufferDepth = *k;
    if (!sort.empty()) s.meshSort = parseMeshSort(sort);
    if (earlyTermination) s.earlyTermination = *earlyTermination;
    if (!lod.empty()) s.lod = parseLodMode(lod);
    if (lodError) s.lodError = *lodError;
    if (cacheMb) s.cacheMb = *cacheMb;
    if (refineBricks) s.refineBricks = *refineBricks;
    if (!skipping.empty()) s.skipping = parseSkipMode(skipping);
    if (noSkipping) s.skipping = SkipMode::Off;
    if (tableSize) s.tableSize = *tableSize;
    if (tableLengths) s.tableLengths = *tableLengths;
    if (!background.empty()) {
        const auto b = parseNumbers(background, 4, "--background");
        s.background = {b[0], b[1], b[2], b[3]};
    }
    if (!nanColor.empty()) {
        const auto c = parseNumbers(nanColor, 4, "--nan-color");
        s.nanColor = {c[0], c[1], c[2], c[3]};
    }
    if (!projection.empty() && projection != "orthographic" && projection != "perspective")
        throw UsageError("--projection '" + projection + "' is unknown (orthographic, perspective)");
    if ((!view.empty() || !orbit.empty()) && (!eye.empty() || !target.empty()))
        throw UsageError("--view/--orbit frame the box themselves: give them without --eye/--target");
    if (!view.empty() && !orbit.empty()) throw UsageError("give --view or --orbit, not both");
    if (!view.empty()) parseNamedView(view);
    if (!orbit.empty()) parseNumbers(orbit, 2, "--orbit");
    if (!up.empty()) parseVec3(up, "--up");
    if (!eye.empty()) parseVec3(eye, "--eye");
    if (!target.empty()) parseVec3(target, "--target");
    if (!tfRange.empty()) parseNumbers(tfRange, 2, "--tf-range");
    const bool shadingGiven = shadingOption && shadingOption->count() > 0;
    if (noShading && shadingGiven) throw UsageError("give --shading or --no-shading, not both");
    for (const auto& text : isos) {
        IsoLayer iso;
        const auto colon = text.find(':');
        iso.value = parseNumbers(text.substr(0, colon), 1, "--iso")[0];
        if (colon != std::string::npos) {
            const auto c = parseNumbers(text.substr(colon + 1), 4, "--iso colour");
            iso.rgba = {c[0], c[1], c[2], c[3]};
        }
        s.effects.isosurfaces.push_back(iso);
    }
    for (const auto& text : lights) {
        Light l;
        std::string spec = text;
        const auto at = spec.find('@');
        if (at != std::string::npos) {
            l.intensity = parseNumbers(spec.substr(at + 1), 1, "--light intensity")[0];
            spec = spec.substr(0, at);
        }
        if (spec == "head")
            l.kind = LightKind::Head;
        else if (spec.rfind("dir:", 0) == 0) {
            l.kind = LightKind::Directional;
            l.vector = parseVec3(spec.substr(4), "--light dir");
        } else if (spec.rfind("point:", 0) == 0) {
            l.kind = LightKind::Point;
            l.vector = parseVec3(spec.substr(6), "--light point");
        } else {
            throw UsageError("--light '" + text + "' is not head, dir:x,y,z or point:x,y,z");
        }
        s.lights.push_back(l);
    }
    if (noShading) {
        s.effects.shading = false;
        s.effects.shadingGiven = true;
    }
    if (shadingGiven) {
        s.effects.shading = true;
        s.effects.shadingGiven = true;
    }
    if (shadingGiven && !shading.empty()) {
        const auto v = parseNumbers(shading, 4, "--shading");
        s.effects.ambient = v[0];
        s.effects.diffuse = v[1];
        s.effects.specular = v[2];
        s.effects.shininess = v[3];
    }
    if (!gradient.empty()) s.effects.gradient = parseGradientKind(gradient);
    if (sobel) s.effects.gradient = GradientKind::Sobel;
    if (shadows) s.effects.shadows = true;
    if (shadowStep) s.effects.shadowStep = *shadowStep;
    if (!shadowMethod.empty())
        s.effects.shadowMethod = shadowMethod == "rays" ? ShadowMethod::Rays : ShadowMethod::Volume;
    if (lightVolumeCell) s.effects.lightVolumeCell = *lightVolumeCell;
    if (!scattering.empty()) {
        const auto v = parseNumbers(scattering, 2, "--scattering");
        s.effects.scattering = true;
        s.effects.albedo = v[0];
        s.effects.phaseG = v[1];
    }
    if (!scatteringOrder.empty()) {
        if (!s.effects.scattering)
            throw UsageError("--scattering-order needs scattering (--scattering or the scene's)");
        s.effects.scatteringOrder =
            scatteringOrder == "multiple" ? ScatteringOrder::Multiple : ScatteringOrder::Single;
    }
    if (samples) s.effects.samples = *samples;
    for (const auto& text : clips) {
        const auto v = parseNumbers(text, 4, "--clip");
        s.effects.clipPlanes.push_back({{v[0], v[1], v[2]}, v[3]});
    }
    if (!cropBox.empty()) s.effects.cropBox = parseCropBoxSpec(cropBox, "--crop-box");
    if (!labels.empty()) {
        if (!s.labels) s.labels = LabelLayer{};
        s.labels->file = labels;
    }
    if ((!labelTable.empty() || !labelMode.empty() || !labelBoundary.empty()) && !s.labels)
        throw UsageError(
            "--label-table, --label-mode and --label-boundary need --labels (or a scene's labels)");
    if (!labelTable.empty()) s.labels->table = labelTable;
    if (!labelMode.empty()) s.labels->mode = parseLabelMode(labelMode);
    if (!labelBoundary.empty()) s.labels->nearest = labelBoundary == "nearest";
    if (s.volume.empty()) throw UsageError("no volume: give --volume or a scene with \"volume\"");
    s.validate();
    return s;
}

namespace {

/// NIfTI and NRRD carry an anatomical frame; their default view is the front (anterior, superior up).
bool isAnatomicalFormat(const std::filesystem::path& p) {
    std::string name = p.filename().string();
    for (auto& c : name)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    auto ends = [&](std::string_view tail) {
        return name.size() >= tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
    };
    return ends(".nii") || ends(".nii.gz") || ends(".nrrd") || ends(".nhdr");
}

/// `v`, a vector of the volume's index frame, in world axes.
Vec3 indexToWorld(const Direction3& d, const Vec3& v) {
    return {d[0] * v[0] + d[1] * v[1] + d[2] * v[2], d[3] * v[0] + d[4] * v[1] + d[5] * v[2],
            d[6] * v[0] + d[7] * v[1] + d[8] * v[2]};
}

} // namespace

std::optional<VczNifti> placeAsVczSource(Volume& v, const VczHeader& h, const std::string& name) {
    v.direction = vczDirection(h);
    v.anatomical = h.metadata.count(std::string(kVczAnatomicalKey)) != 0;
    auto nifti = niftiFromVczMetadata(h.metadata, name);
    if (nifti) { // the source header travels in the file: frame it as the .nii is framed
        v.direction = niftiDirection(nifti->meta);
        v.anatomical = true;
    }
    return nifti;
}

UsageError SceneFlags::namingSceneFile(const UsageError& e) const {
    const std::string what = e.what();
    if (scene.empty() || what.rfind(scene, 0) == 0) return e;
    return UsageError(scene + ": " + what);
}

std::vector<std::string> SceneFlags::finish(Scene& s, const Volume& v) const {
    return finish(s, RenderInput::borrow(v));
}

std::vector<std::string> SceneFlags::finish(Scene& s, const RenderInput& in) const {
    std::vector<std::string> notes;
    const WorldBox box = in.bounds();
    if (std::string note = resolveStep(s, in.cellLength()); !note.empty()) notes.push_back(std::move(note));
    if (std::string note = in.resolveCropBox(s); !note.empty()) notes.push_back(std::move(note));
    // Refuse impossible steps before any other default is applied or reported: the error is the only line,
    // naming the scene file the steps came from when there is one.
    try {
        s.validateSteps(norm(box.extent));
    } catch (const UsageError& e) {
        throw namingSceneFile(e);
    }
    const double aspect = double(s.width) / double(s.height);
    const bool anyCameraFlag = !projection.empty() || !eye.empty() || !target.empty() || !up.empty() ||
                               viewHeight || fov || !view.empty() || !orbit.empty();
    // Named views, orbits and the default view are in world axes (patient RAS for anatomical data); the
    // camera is carried into the volume's index frame, where the renderers march.
    const Volume* grid = in.grid();
    const Direction3 direction = grid ? grid->direction : kIdentityDirection;
    const bool anatomical = isAnatomicalFormat(s.volume) || (grid && grid->anatomical);
    // What the scene file's camera gave: a partial one is completed below exactly as flags would be.
    const CameraFieldsGiven given = s.camera ? s.cameraGiven : CameraFieldsGiven{false, false, false, false};
    const bool partialScene = s.camera && !given.complete(s.camera->projection);
    if (anyCameraFlag || (!s.camera && anatomical) || partialScene) {
        const Camera base = s.camera ? *s.camera : Camera{};
        Projection proj = base.projection;
        if (!projection.empty())
            proj = projection == "perspective" ? Projection::Perspective : Projection::Orthographic;
        else if (fov)
            proj = Projection::Perspective;
        const double fovY = fov ? *fov : base.fovYDeg;
        const bool haveEye = !eye.empty() || given.eye, haveTarget = !target.empty() || given.target;
        const bool haveUp = !up.empty() || given.up;
        const ViewDirection defaultDir =
            namedViewDirection(anatomical ? NamedView::Front : NamedView::Bottom);
        Camera c = base;
        const bool framed = !view.empty() || !orbit.empty() || (!haveEye && !haveTarget);
        if (framed) {
            ViewDirection dir = defaultDir;
            if (!orbit.empty()) {
                const auto ae = parseNumbers(orbit, 2, "--orbit");
                dir = orbitDirection(ae[0], ae[1]);
            } else if (!view.empty()) {
                dir = namedViewDirection(parseNamedView(view));
            }
            if (!up.empty())
                dir.up = parseVec3(up, "--up");
            else if (given.up && view.empty() && orbit.empty())
                dir.up = indexToWorld(direction, base.up); // framing turns the scene's up back
            c = frameOrientedBox(box, direction, dir, proj, fovY, aspect);
            // A height the scene gave is kept when only the camera's position was left to framing.
            if (given.height && view.empty() && orbit.empty()) c.height = base.height;
            if (!s.camera && view.empty() && orbit.empty() && anatomical)
                notes.push_back(grid && grid->anatomical
                                    ? "camera: front view (anterior toward the camera, superior up; "
                                      "--view/--orbit choose others)"
                                    : "camera: front view of the box (+z up; --view/--orbit choose others)");
            else if (partialScene && view.empty() && orbit.empty())
                notes.push_back("camera: the scene gives no eye or target: the box is framed from the " +
                                std::string(anatomical ? "front" : "bottom") + " view");
        } else {
            c.projection = proj;
            c.fovYDeg = fovY;
            if (!target.empty())
                c.target = parseVec3(target, "--target");
            else if (!given.target)
                c.target = boxCentre(box);
            if (!eye.empty()) {
                c.eye = parseVec3(eye, "--eye");
            } else if (!given.eye) {
                // Seen from the default view at the distance framing would choose (perspective: the box fills
                // the view; orthographic: outside the box).
                const Camera fitted = frameOrientedBox(box, direction, defaultDir, proj, fovY, aspect);
                c.eye = volcl::add(c.target, sub(fitted.eye, fitted.target));
                c.mirrored = fitted.mirrored;
                if (!haveUp) c.up = fitted.up;
            }
            if (!up.empty()) c.up = parseVec3(up, "--up");
            // No up given and the default one runs along the view: take the next axis instead.
            if (!haveUp && norm(cross(sub(c.target, c.eye), c.up)) <= 1e-9 * norm(sub(c.target, c.eye)))
                c.up = Vec3{0, 0, 1};
            // No height for this camera: neither --view-height nor the scene camera gave one.
            if (!given.height && !viewHeight && c.projection == Projection::Orthographic) {
                c.height = fittedOrthographicHeight(c, box, aspect);
                std::ostringstream os;
                os << "camera: orthographic height " << c.height
                   << " fitted to the box (--view-height sets it)";
                notes.push_back(os.str());
            }
        }
        if (viewHeight) c.height = *viewHeight;
        if (norm(sub(c.target, c.eye)) == 0.0) throw UsageError("camera: the eye and the target coincide");
        if (norm(cross(sub(c.target, c.eye), c.up)) == 0.0)
            throw UsageError("camera: the up vector is parallel to the view direction (give --up)");
        s.camera = c;
        s.cameraGiven = {};
    }
    for (auto& n : applyLightingDefaults(s))
        notes.push_back(std::move(n));
    s.validate();
    return notes;
}

Volume SceneFlags::readSceneVolume(const Scene& s, std::vector<std::string>& notes,
                                   std::vector<std::filesystem::path>* filesRead) const {
    if (s.volume.extension() == ".vcz") { // decoded whole (`volcl render` draws .vcz from its bricks instead)
        const VczReader r(readFileBytes(s.volume), s.volume.string());
        const std::size_t k = frame.value_or(0);
        if (k >= r.header().frames.size())
            throw UsageError("--frame " + std::to_string(k) + " out of range: " + s.volume.string() +
                             " has " + std::to_string(r.header().frames.size()) + " frame(s)");
        if (!frame && r.header().frames.size() > 1)
            notes.push_back("rendering frame 0 of " + std::to_string(r.header().frames.size()) +
                            " (--frame K picks another)");
        if (filesRead) *filesRead = {s.volume};
        ComputeContext cc(device);
        Volume v = r.decodeFrame(cc, k);
        const auto n = placeAsVczSource(v, r.header(), s.volume.string());
        if (!n) return v;
        // The stored integers of a scaled NIfTI are shown in data units, as the .nii itself is.
        return n->storedValues ? niftiDataUnits(v, n->meta) : v;
    }
    std::vector<std::filesystem::path> files;
    TimeSeries ts = readVolumeFile(s.volume, raw.toReadOptions(), files);
    if (filesRead) *filesRead = std::move(files);
    const std::size_t k = frame.value_or(0);
    if (k >= ts.frames.size())
        throw UsageError("--frame " + std::to_string(k) + " out of range: " + s.volume.string() + " has " +
                         std::to_string(ts.frames.size()) + " frame(s)");
    if (!frame && ts.frames.size() > 1)
        notes.push_back("rendering frame 0 of " + std::to_string(ts.frames.size()) +
                        " (--frame K picks another)");
    return std::move(ts.frames[k]);
}

double paraViewUnitDistance(const Volume& v) {
    return RenderInput::borrow(v).approximateCellLength();
}

RenderInput SceneFlags::readSceneInput(const Scene& s, std::vector<std::string>& notes,
                                       std::vector<std::filesystem::path>* filesRead) const {
    if (meshcodec::isMeshFile(s.volume)) {
        if (filesRead) *filesRead = {s.volume};
        return RenderInput::openMesh(s.volume, mesh.toReadOptions());
    }
    if (s.volume.extension() == ".vcz" && s.lod == LodMode::Auto) {
        // Drawn from its bricks, read and decoded as the view needs them (volumes larger than memory), as
        // `volcl render` does; a scaled NIfTI source's stored integers need the data-unit mapping only
        // `render` makes, so such a file is decoded whole.
        RenderInput in = RenderInput::openVcz(s.volume, frame.value_or(0));
        Volume geometry; // header only: placeAsVczSource reads the NIfTI keys, never the voxels
        const auto nifti = placeAsVczSource(geometry, in.bricks()->header(), s.volume.string());
        if (!nifti || !nifti->storedValues) {
            if (!frame && in.bricks()->header().frames.size() > 1)
                notes.push_back("rendering frame 0 of " +
                                std::to_string(in.bricks()->header().frames.size()) +
                                " (--frame K picks another)");
            if (filesRead) *filesRead = {s.volume};
            return in;
        }
        notes.push_back(
            "--lod auto: the stored integers of a scaled NIfTI are decoded whole to show data units");
    }
    Volume v = readSceneVolume(s, notes, filesRead);
    if (v.type() == ScalarType::Float64)
        notes.push_back("float64 voxels are rendered as float32 (the kernels sample float32)");
    return RenderInput::fromVolume(std::move(v));
}

TransferFunction SceneFlags::loadTf(const Scene& s, const Volume& v, std::vector<std::string>* notes) const {
    return loadTf(s, RenderInput::borrow(v), notes);
}

TransferFunction SceneFlags::loadTf(const Scene& s, const Volume& v, std::array<double, 2> dataRange,
                                    std::vector<std::string>* notes) const {
    return loadTf(s, RenderInput::borrow(v), dataRange, notes);
}

TransferFunction SceneFlags::loadTf(const Scene& s, const RenderInput& in,
                                    std::vector<std::string>* notes) const {
    if (const Volume* v = in.grid()) {
        const VolumeStats vs = v->stats(1);
        return loadTf(s, in, {vs.min, vs.max}, notes);
    }
    const ValueRange r = in.valueRange();
    return loadTf(s, in, {r.min, r.max}, notes);
}

TransferFunction SceneFlags::loadTf(const Scene& s, const RenderInput& in, std::array<double, 2> dataRange,
                                    std::vector<std::string>* notes) const {
    auto note = [&](std::string text) {
        if (notes) notes->push_back(std::move(text));
    };
    // The transfer function shows in dvr, in MIP coloured by it, and in shadows or scattering; grey MIP,
    // x-ray and iso surfaces draw without it, so its defaults go unmentioned there.
    const bool tfShows =
        s.mode == RenderMode::Dvr || (s.mode == RenderMode::Mip && s.mipColor != MipColor::Grey);
    double unit = 1.0;
    if (tfUnitDistance == "auto") {
        unit = in.approximateCellLength();
        if (tfShows)
            note("opacity unit distance " + formatNumber(unit) +
                 " world units: ParaView's automatic one, box diagonal / cube root of the cell count "
                 "(--tf-unit-distance sets it)");
    } else {
        unit = parseNumbers(tfUnitDistance, 1, "--tf-unit-distance")[0];
    }
    if (!(std::isfinite(unit) && unit > 0.0)) throw UsageError("--tf-unit-distance must be > 0 or 'auto'");
    std::optional<std::array<double, 2>> range;
    if (!tfRange.empty()) {
        const auto r = parseNumbers(tfRange, 2, "--tf-range");
        if (!(r[0] < r[1])) throw UsageError("--tf-range: LO must be below HI");
        range = std::array<double, 2>{r[0], r[1]};
    }
    if (s.tf.empty() && tfShows) {
        const std::array<double, 2> over = range ? *range : dataRange;
        note("transfer function: ParaView's default, a grey ramp with opacity 0 to 1 over " +
             std::string(range ? "--tf-range " : "the data range ") + "[" + formatNumber(over[0]) + ", " +
             formatNumber(over[1]) + "] (--tf sets one)");
    }
    return TransferFunction::forRender(
        s.tf.empty() ? std::nullopt : std::optional<std::filesystem::path>(s.tf), dataRange, unit, range);
}

} // namespace volcl::cli
