// Render scenes (docs/contract.md): camera, image, mode, lights and effects, read from JSON.
#pragma once

#include "render/Bounds.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

struct Scene;

/// Emission: the emission-only model, the integral of the TF's colour x opacity per unit distance along the
/// ray with no absorption (docs/rendering.md, "Emission only").
enum class RenderMode { Dvr, Mip, Iso, Xray, Emission };
enum class Preintegration { None, Table2d, Table3d };
enum class Projection { Orthographic, Perspective };
enum class LightKind { Directional, Point, Head };
/// Gradients for shading: on the fly by central differences or Sobel, or from the gradient cache built once
/// per volume (grids only: cl/common/gradient_cache.h), blended trilinearly or taken from the nearest voxel.
enum class GradientKind { Central, Sobel, Cache, CacheNearest };
/// How shadows find the transmittance toward a light: one fetch per sample in a light-attenuation volume
/// built per light (render/grid/LightVolume.hpp), or a secondary ray marched per sample (the exact method).
enum class ShadowMethod { Volume, Rays };
/// How samples and gradients are reconstructed from the grid: trilinear with finite-difference gradients;
/// an interpolating cubic B-spline (prefiltered coefficients, C2, passes through the voxels); or the
/// smoothing cubic B-spline of the voxels themselves (no prefilter: removes quantisation terraces). Both
/// cubic filters take the gradient as the analytic derivative of the field.
enum class ReconstructionFilter { Linear, Cubic, Bspline };
/// What a MIP pixel shows: the windowed maximum as grey, the TF colour at the maximum brightened by the
/// window, or the TF's own colour and opacity at the maximum.
enum class MipColor { Grey, Tf, TfOpacity };
/// Scattering order: single scattering inside the ray marcher, or multiple scattering by the Monte Carlo path
/// tracer (cl/render/pathtrace.cl).
enum class ScatteringOrder { Single, Multiple };
/// Level of detail of compressed-brick inputs (.vcz): level 0 everywhere, or a level per brick from its
/// estimated screen-space error (render/bricks/BrickLod.hpp).
enum class LodMode { Full, Auto };
/// How a tetrahedral mesh is rendered: exact cell-by-cell traversal, faces sorted by centroid into a
/// per-pixel k-buffer of depth render.k, or projected tetrahedra composited in a visibility order of the cells
/// (render.sort) (grids ignore it).
enum class MeshMethod { Cells, KBuffer, ProjectedTetrahedra };
/// How render.method "pt" orders cells (render/mesh/VisibilitySort.hpp defines it).
enum class MeshSort;
/// How a grid is rendered: the ray marcher (full quality), or a preview tier: shear-warp of a run-length-encoded
/// classified volume (orthographic views), or discrete ray casting (nearest voxel, 3D DDA). Meshes and
/// compressed bricks ignore it.
enum class GridMethod { Raymarch, ShearWarp, Drc };
/// Empty-space skipping: chosen per volume and TF by measuring a probe frame (Auto), always, or never.
enum class SkipMode { Auto, On, Off };

std::string_view renderModeName(RenderMode m);
RenderMode parseRenderMode(std::string_view s); ///< throws UsageError
std::string_view preintegrationName(Preintegration p);
Preintegration parsePreintegration(std::string_view s); ///< "none", "2d", "3d"; throws UsageError
std::string_view filterName(ReconstructionFilter f);
ReconstructionFilter parseFilter(std::string_view s); ///< "linear", "cubic", "bspline"; throws UsageError
std::string_view mipColorName(MipColor c);
MipColor parseMipColor(std::string_view s); ///< "grey" (or "gray"), "tf", "tf-opacity"; throws UsageError
std::string_view lodModeName(LodMode m);
LodMode parseLodMode(std::string_view s); ///< "full", "auto"; throws UsageError
std::string_view gradientKindName(GradientKind g);
GradientKind
parseGradientKind(std::string_view s); ///< "central", "sobel", "cache", "cache-nearest"; throws UsageError
std::string_view meshMethodName(MeshMethod m);
MeshMethod parseMeshMethod(std::string_view s); ///< "cells", "kbuffer", "pt"; throws UsageError
std::string_view gridMethodName(GridMethod m);
/// Sets render.method from `s`: a mesh method ("cells", "kbuffer", "pt") or a grid method ("raymarch",
/// "shear-warp", "drc"); throws UsageError naming `what` for anything else.
void parseRenderMethod(std::string_view s, const std::string& what, Scene& scene);
std::string_view skipModeName(SkipMode m);
SkipMode parseSkipMode(std::string_view s); ///< "auto", "on", "off"; throws UsageError

/// GLM lookAt camera. `height` is the orthographic view height in world units; `fovYDeg` the perspective one.
struct Camera {
    Projection projection = Projection::Orthographic;
    Vec3 eye{0, 0, -1}, target{0, 0, 0}, up{0, 1, 0};
    double height = 1.0;
    double fovYDeg = 30.0;
    /// Image x runs along -(forward x up) instead of +: a camera carried into the index frame of a volume
    /// whose direction mirrors (determinant -1, e.g. LAS) still shows world's left on the image left.
    bool mirrored = false;
};

/// Which camera fields a scene file gave. A camera missing its eye, target, up or (orthographic) height is
/// completed from the volume's box the way the command line completes one (the CLI's SceneFlags::finish):
/// a missing target is the box centre, a missing eye looks at it from the default view at a fitted
/// distance, a missing height shows the whole box, a missing up is the view's own.
struct CameraFieldsGiven {
    bool eye = true, target = true, up = true, height = true;
    /// Everything a renderer needs is there (perspective cameras need no height).
    bool complete(Projection p) const noexcept {
        return eye && target && up && (height || p == Projection::Perspective);
    }
};

/// A light: direction toward the light (directional), position (point), or at the eye (head).
struct Light {
    LightKind kind = LightKind::Directional;
    Vec3 vector{0, 0, -1};
    Vec3 color{1, 1, 1};
    double intensity = 1.0;
};

/// A transparent or opaque iso-surface: straight colour and opacity.
struct IsoLayer {
    double value = 0.0;
    std::array<double, 4> rgba{1, 1, 1, 1};
};

/// Keeps the half-space dot(normal, x) + offset >= 0.
struct ClipPlane {
    Vec3 normal{1, 0, 0};
    double offset = 0.0;
};

/// Clip planes a frame may have, the crop box's six included (the kernels' VOLCL_MAX_CLIP_PLANES).
inline constexpr std::size_t kMaxClipPlanes = 8;
inline constexpr std::size_t kCropBoxPlanes = 6;

/// A cropping box (effects.crop_box, --crop-box): keeps lo <= x <= hi on every axis, in the frame the clip
/// planes and cameras live in (the volume's index-aligned frame, origin + diag(spacing) (i, j, k)), or in
/// voxel indices (i, j, k) until resolveCropBox() turns them into that frame's units. It is six clip planes,
/// counted against kMaxClipPlanes; a box outside the data renders the background.
struct CropBox {
    Vec3 lo{0, 0, 0}, hi{0, 0, 0};
    bool voxels = false;
};

/// Fog (docs/media.md): with h = dot(p, normalize(up)), extinction `density` where h <= base and
/// density * exp(-(h - base) / falloff) above (falloff 0: none above), emission color * extinction, only
/// inside `box` (absent: the volume's box). A height map replaces `base` per texel of the ground plane.
struct FogEffect {
    bool enabled = false; ///< the scene has an "effects.fog" object
    double density = 0.0, base = 0.0, falloff = 0.0;
    Vec3 color{1, 1, 1};
    Vec3 up{0, 1, 0};
    std::optional<WorldBox> box;
    /// Image (grey or R channel) giving the fog top (the base) over the ground plane; empty: none. The
    /// map spans the box's two axes other than `up` (which must then be a coordinate axis): image x along
    /// the lower-numbered axis, image row 0 at the low end of the other. Value v maps to
    /// heightRange[0] + v * (heightRange[1] - heightRange[0]); absent range: the box's extent along up.
    std::filesystem::path heightMap;
    std::optional<std::array<double, 2>> heightRange;
};

/// What a scene asks for; Effects planning decides what is compiled (see planEffects()).
struct SceneEffects {
    bool shading = false;      ///< Blinn-Phong requested ("shading" object present)
    bool shadingGiven = false; ///< the scene or a flag said whether to shade (iso mode shades unless told)
    double ambient = 0.2, diffuse = 0.7, specular = 0.3, shininess = 32.0;
    /// Shade through the pre-integrated lighting table (2D pre-integration): gradients at both segment ends,
    /// diffuse weighted by the table's front/back terms, specular at the table's emission centroid.
    bool shadingPreintegrated = false;
    /// Meshes: shade with vertex normals interpolated inside each tet (render/mesh/VertexNormals.hpp) instead of
    /// each tet's constant gradient ("normals": "smooth" | "flat"). Grids take the gradient at the sample.
    bool smoothNormals = true;
    /// Iso-surfaces from the iso-surface table of the segment's end values (iso mode) instead of the exact
    /// per-cell roots ("isosurface_method": "table" | "roots").
    bool isoTable = false;
    GradientKind gradient = GradientKind::Cache;
    bool shadows = false;
    double shadowStep = 1.0;                          ///< world units; 0 = the render step
    ShadowMethod shadowMethod = ShadowMethod::Volume; ///< "shadow_method": "volume" | "rays"
    int lightVolumeCell = 1; ///< "light_volume_cell": voxels per light-volume cell edge (1 = every voxel)
    /// "shadow_head_tolerance": degrees a head light may turn (as seen from the volume's centre) before its
    /// light volume is rebuilt; 0 rebuilds on every move.
    double headLightToleranceDeg = 1.0;
    double albedo = 0.0, phaseG = 0.0; ///< single scattering when albedo > 0 ("scattering" object)
    bool scattering = false;
    ScatteringOrder scatteringOrder = ScatteringOrder::Single;
    int samples = 64;          ///< path tracer: samples per pixel
    int maxBounces = 64;       ///< path tracer: scattering events per path
    std::uint32_t seed = 1;    ///< path tracer: same seed, same image
    Vec3 environment{0, 0, 0}; ///< path tracer: radiance of a uniform sky around the volume
    bool emission = true;      ///< the TF's emission c * tau adds to the scattered light
    int octaves = 0; ///< single scattering: > 0 approximates multiple scattering by that many octaves
    std::vector<ClipPlane> clipPlanes;
    std::optional<CropBox> cropBox;
    std::vector<IsoLayer> isosurfaces;
    FogEffect fog;
};

/// How a label map combines with the intensity volume's transfer function (docs/labels.md): the labels alone,
/// the label colour and opacity replacing the TF's inside visible labels, or the TF's opacity scaled by the
/// label's opacity and its colour by the label's colour.
enum class LabelMode { Replace, Modulate, Alone };
std::string_view labelModeName(LabelMode m);
LabelMode
parseLabelMode(std::string_view s); ///< "replace", "modulate", "alone"; throws UsageError naming `what`

/// A label map over the scene's volume (scene "labels", --labels): an integer volume looked up in world
/// coordinates, a label table (empty: the default palette) and the mode. `nearest`: the nearest voxel's label
/// with full opacity (the staircase boundary, for comparison) instead of the smooth boundary.
struct LabelLayer {
    std::filesystem::path file, table;
    LabelMode mode = LabelMode::Replace;
    bool nearest = false;
};

/// One channel of a multi-channel scene (`"channels"`, docs/channels.md): its transfer function (a file or
/// "preset:NAME"; empty: ParaView's default over the channel's range), whether it shows, and where it comes
/// from (default: the scene's volume, component = the entry's position; a file of its own gives its channel 0
/// unless `channel` says otherwise).
struct SceneChannel {
    std::filesystem::path tf;
    bool visible = true;
    std::filesystem::path volume;
    std::optional<std::size_t> channel;
};

/// A complete scene. Paths are resolved against the scene file's folder. Example:
/// ```
/// volcl::Scene s = volcl::Scene::fromFile("head.json");
/// s.width = 256;                       // flags override fields
/// s.validate();
/// ```
struct Scene {
    std::filesystem::path volume, tf; ///< volume: the data file; RenderInput::open picks its renderer
    /// Multi-channel scenes: one entry per channel, blended by `channelBlend` ("additive" or "max");
    /// `directColor` ("color": "direct") draws 3 or 4 channels as RGB(A), opacity through `tf`.
    std::vector<SceneChannel> channels;
    std::string channelBlend = "additive";
    bool directColor = false;
    /// The scene draws several channels (channels given, or direct colour).
    bool multiChannel() const noexcept { return !channels.empty() || directColor; }
    std::optional<Camera> camera;  ///< absent: defaultCamera() looks down +z at the data's whole box
    CameraFieldsGiven cameraGiven; ///< from a scene file: the fields it gave (the rest are fitted)
    int width = 512, height = 512;
    std::array<double, 4> background{0, 0, 0, 1};
    /// Colour of samples that are not finite (NaN/Inf voxels): straight r, g, b and opacity per unit
    /// distance, as a TF's; transparent by default (docs/rendering.md, "NaN and Inf").
    std::array<double, 4> nanColor{0, 0, 0, 0};
    RenderMode mode = RenderMode::Dvr;
    double step = 0.5; ///< world units: what the renderers sample at
    /// The step in voxels of the finest grid spacing (a mesh: ParaView's approximate cell length), from
    /// `"step": "0.5vox"`, `--step 0.5vox`, or a scene file or command line that gives no step
    /// (kDefaultStepVoxels); resolveStep() turns it into `step` once the input is known.
    std::optional<double> stepVoxels;
    Preintegration preintegration = Preintegration::None;
    double earlyTermination = 0.995; ///< 1 disables early termination
    /// Auto: grids measure skipping (macrocell edges and off) on a probe frame per TF and volume and keep the
    /// fastest; bricks and meshes treat Auto as On.
    SkipMode skipping = SkipMode::Auto;
    int tableSize = 256;   ///< pre-integration table nodes
    int tableLengths = 16; ///< 3D table: lengths between step / L and step
    ReconstructionFilter filter = ReconstructionFilter::Linear;
    /// Gaussian smoothing (sigma in voxels) of the data before any filter reads it; 0: none.
    double smoothing = 0.0;
    /// MIP window (centre, width) in data values; absent: the data's value range.
    std::optional<std::array<double, 2>> window;
    MipColor mipColor = MipColor::Grey;
    /// Frame-time budget (kernel milliseconds): the planner picks scattering order, samples and step; 0: none.
    double budgetMs = 0.0;
    /// Compressed-brick inputs only: level of detail, its error threshold and the decoded-brick budget.
    LodMode lod = LodMode::Full;
    double lodError = 0.01;
    double cacheMb = 512.0;
    /// `view --lod auto`: missing bricks decoded per still frame while it refines, exactly this many (absent:
    /// the device profile's count plus those whose predicted decode fits its share of the last kernel time).
    std::optional<std::size_t> refineBricks;
    MeshMethod meshMethod = MeshMethod::Cells;    ///< render.method (meshes only)
    GridMethod gridMethod = GridMethod::Raymarch; ///< render.method (grids only)
    int kBufferDepth = 6;                         ///< render.k: k-buffer entries per pixel, 2..8
    /// render.sort: the cell order of projected tetrahedra; unset: mpvo for a convex mesh, else convexified
    /// (defaultMeshSort).
    std::optional<MeshSort> meshSort;
    std::vector<Light> lights;
    SceneEffects effects;
    std::optional<LabelLayer> labels; ///< "labels": a label map drawn with the volume

    static Scene fromJson(std::string_view json, const std::filesystem::path& baseDir = {});
    static Scene fromFile(const std::filesystem::path& path);
    std::string toJson() const;
    /// Throws UsageError naming the field for out-of-range values.
    void validate() const;
    /// Refuses (UsageError) steps that would make one ray too long for a volume whose world-space diagonal
    /// is `worldDiagonal`: render.step and effects.shadow_step each at most 5e7 samples across it; and a
    /// frame whose worst case, pixels x samples per ray x (1 + lights x shadow samples per sample when
    /// shadows are on), exceeds kMaxSamplesPerFrame.
    void validateSteps(double worldDiagonal) const;
    /// Samples one frame may take: 2^37, so a 4096^2 image of a 1024^3 volume at a quarter-voxel step
    /// (4096^2 x 1024 sqrt(3) / 0.25 = 1.19e11) stays allowed.
    static constexpr double kMaxSamplesPerFrame = 137438953472.0;
};

/// The step of a scene file or command line that gives none: half a voxel of the finest spacing.
inline constexpr double kDefaultStepVoxels = 0.5;

/// A step as written in a scene (`"step"`) or on a command line (`--step`): a number in world units, or a
/// number followed by `vox` in voxels of the finest spacing. Throws UsageError naming `what`.
struct StepSpec {
    double value = 0.5;
    bool voxels = false;
};
StepSpec parseStepSpec(const std::string& text, const std::string& what);

/// Sets `scene.step` from `scene.stepVoxels` (when set) and `cellLength`, the input's finest grid spacing
/// or a mesh's approximate cell length, and clears stepVoxels. Returns the note saying so (empty when the
/// step was already in world units).
std::string resolveStep(Scene& scene, double cellLength);

/// A crop box as written on a command line (`x0,y0,z0:x1,y1,z1`, a `vox` suffix for voxel indices). Throws
/// UsageError naming `what`.
CropBox parseCropBoxSpec(const std::string& text, const std::string& what);

/// Turns a crop box in voxels into the units of a grid with `origin` and `spacing` (index i lies at
/// origin + spacing i); returns the note saying so (empty when the box was already in world units).
std::string resolveCropBox(Scene& scene, const Vec3& origin, const Vec3& spacing);

/// The six planes of a crop box in world units, in the order x >= lo, x <= hi, y >= lo, ... .
std::vector<ClipPlane> cropBoxPlanes(const CropBox& box);

/// Every plane that clips the frame: the scene's clip planes, then the crop box's six. Throws UsageError when
/// the crop box is still in voxels (resolveCropBox() has not seen the input).
std::vector<ClipPlane> activeClipPlanes(const SceneEffects& effects);

/// Fills in what a scene leaves to defaults, before planning: iso mode shades when nothing says otherwise,
/// and shading (or scattering, or shadows) with no lit light gets a head light. Returns one line per change
/// (for a stderr note and `--explain`).
std::vector<std::string> applyLightingDefaults(Scene& scene);

/// Orthographic camera along +z through the centre of a world box, sized to show all of it (every
/// renderer's default: the box is VolumeRenderer::bounds()).
Camera defaultCamera(const WorldBox& box);

/// World-space ray of pixel (x, y) (y = 0 at the top), double precision (lookAt convention).
struct CameraRay {
    Vec3 origin, direction;
};
CameraRay cameraRay(const Camera& camera, int width, int height, double x, double y);

} // namespace volcl
