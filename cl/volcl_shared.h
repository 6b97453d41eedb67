/* Structs shared by host C++ and OpenCL C: one definition, same layout on both sides. */
#ifndef VOLCL_SHARED_H
#define VOLCL_SHARED_H

#ifdef __OPENCL_VERSION__
typedef uint volcl_uint;
typedef int volcl_int;
#else
#include <cstdint>
typedef std::uint32_t volcl_uint;
typedef std::int32_t volcl_int;
#endif

/* One interval of a merged transfer function, starting at knot s. Channels are (r, g, b, tau).
   Inside (s, next.s] the value is value + (x - s) * slope. Below the first knot the first knot's value
   holds; above the last, the last knot's value (slope 0). */
typedef struct VolclTfKnot {
    float value[4];
    float slope[4];
    float s;
    float pad[3];
} VolclTfKnot;

/* One widget of a 2D transfer function (host/tf/TransferFunction.hpp, TfWidget), stored in the knot buffer
   after the gradient-opacity knots, one knot's 48 bytes each. shape 0 (box): w = 1 on [a[0], a[1]] x
   [a[2], a[3]] of (value, gradient magnitude); shape 1 (Gaussian): a = (centre value, 1 / sigma value,
   centre gradient, 1 / sigma gradient). Adds extinction rgbTau[3] * w of colour rgbTau[0..2]. Shape 2
   (ParaView box) on the box a: opacity rgbTau[3] * ParaView's Gaussian (TfWidget::extinction), extinction
   -ln(1 - opacity) * invUnitDistance, at most VOLCL_MAX_IMPORTED_EXTINCTION * invUnitDistance. */
#define VOLCL_PARAVIEW_BOX_SIGMA 0.3f
#define VOLCL_MAX_IMPORTED_EXTINCTION 1000.0f
typedef struct VolclTfWidget {
    float rgbTau[4];
    float a[4];
    volcl_uint shape;
    float invUnitDistance;
    volcl_uint pad[2];
} VolclTfWidget;

/* One ellipsoid of the 3D Shepp-Logan phantom: p' = rot * p; inside when
   sum(((p' - centre) * invSemiAxis)^2) <= 1; adds `value` to the density. */
typedef struct VolclEllipsoid {
    float rot[9];
    float centre[3];
    float invSemiAxis[3];
    float value;
} VolclEllipsoid;

/* Renderers (cl/raymarch*.cl today; mesh and brick renderers alike). A frame's parameters come in one
   struct per concern, so a kernel family passes the ones it uses and the helpers in cl/common/ take only
   theirs: camera_rays.h reads VolclCameraParams and VolclClipParams, shading.h VolclLightingParams,
   tf_lookup.h VolclTfParams, grid_sample.h VolclGridParams. Values that change per frame live here, not in
   -D defines, so changing the camera or the TF never rebuilds a kernel. Vectors are xyz + one spare float;
   every struct is a multiple of 16 bytes of 4-byte fields, so host and device agree on the layout. */
#define VOLCL_MAX_LIGHTS 4
#define VOLCL_MAX_CLIP_PLANES 8
#define VOLCL_MAX_ISOSURFACES 4

/* Light kinds (VolclLightingParams::lightPos[i][3]). */
#define VOLCL_LIGHT_DIRECTIONAL 0
#define VOLCL_LIGHT_POINT 1
#define VOLCL_LIGHT_HEAD 2

/* Mesh cell records: the neighbour of a boundary face on the mesh's convex hull (no re-entry past it); other
   boundary faces hold 0xFFFFFFFF. Above every face id (tet * 4 + face, tets < 2^30 - 1). */
#define VOLCL_MESH_HULL_FACE 0xFFFFFFFEu
/* Mesh BVH nodes (leaf count word): set when a face below belongs to a tet that overlaps another tet. */
#define VOLCL_MESH_BVH_OVERLAP 0x80000000u

/* Camera and image: pixel (x, y) -> world ray. */
typedef struct VolclCameraParams {
    float origin[4];  /* orthographic: eye; perspective: eye */
    float right[4];   /* r scaled by the half-width of the view (world units or tan(fov/2) * aspect) */
    float up[4];      /* u scaled by the half-height of the view */
    float forward[4]; /* f */
    volcl_uint width, height, perspective, pad0;
} VolclCameraParams;

/* Clip planes: keep points with dot(n, x) + w >= 0 (n unit length). */
typedef struct VolclClipParams {
    volcl_uint count, pad0, pad1, pad2;
    float plane[VOLCL_MAX_CLIP_PLANES][4];
} VolclClipParams;

/* The march along a ray: sampling distance (world units), the opacity that ends a ray, and the MIP window
   (lower end and 1 / width, in data values). */
typedef struct VolclMarchParams {
    float step, earlyTermination, windowLo, windowInvWidth;
} VolclMarchParams;

/* Transfer function (knots in their own buffer) and pre-integration table geometry. A gradient TF
   (TF_GRADIENT) keeps gradientKnotCount gradient-opacity knots and widgetCount VolclTfWidget records after the
   knotCount knots of the value axis. */
typedef struct VolclTfParams {
    volcl_uint knotCount, tableSize, tableLengths, gradientKnotCount;
    float domainLo, domainHi;
    float tableMaxLength; /* segment length of the 2D table, of the last slice of the 3D table */
    volcl_uint widgetCount;
} VolclTfParams;

/* Lights, Blinn-Phong and single-scattering coefficients, shadow rays. */
typedef struct VolclLightingParams {
    volcl_uint lightCount, pad0, pad1, pad2;
    float ambient, diffuse, specular, shininess;
    float albedo, phaseG;
    float gradientMin;                     /* gradient magnitude below which a sample has no normal */
    float shadowStep;                      /* world units */
    float lightPos[VOLCL_MAX_LIGHTS][4];   /* xyz: direction toward the light or position; w: kind */
    float lightColor[VOLCL_MAX_LIGHTS][4]; /* rgb * intensity */
} VolclLightingParams;

/* Iso-surfaces composited where the field crosses value[i]. */
typedef struct VolclIsoParams {
    volcl_uint count, pad0, pad1, pad2;
    float value[VOLCL_MAX_ISOSURFACES];
    float color[VOLCL_MAX_ISOSURFACES][4]; /* straight rgb, opacity */
} VolclIsoParams;

/* A node-centred grid (x fastest) and its macrocells. */
typedef struct VolclGridParams {
    float origin[4]; /* world position of voxel (0,0,0) */
    float spacing[4];
    float invSpacing[4];
    volcl_uint dims[4];      /* nx, ny, nz, spare */
    volcl_uint macroDims[4]; /* macrocells per axis, voxels per macrocell edge */
    float gradientMax;       /* the gradient cache's scale: a bound on the L1 norm of any voxel's gradient */
    float gradientPad[3];
} VolclGridParams;

/* Fog (cl/common/fog.h): extinction density where dot(x, up) <= base, density * exp(-(h - base) * invFalloff)
   above (invFalloff < 0: none above), emission color * extinction, inside the world box [lo, hi]. With a
   height map (FOG_MAP) the base is the map's texel under x: map axes mapAxis[0] (image x) and mapAxis[1]
   (image y) over the box, mapSize texels. */
typedef struct VolclFogParams {
    float up[4];    /* unit up; w: base */
    float color[4]; /* rgb; w: density */
    float lo[4];    /* box corner; w: 1 / falloff (0 for falloff -> infinity, -1 for falloff 0) */
    float hi[4];    /* box corner; w: spare */
    volcl_uint mapAxis[2], mapSize[2];
} VolclFogParams;

/* Light-attenuation volumes (cl/common/light_volume.h): optical depth toward each light at the nodes of a
   node-centred grid spanning the volume's box, dims[0..2] nodes per axis, dims[3] nodes per light (light i's
   nodes start at i * dims[3], x fastest); toLight: light-grid coordinates per voxel coordinate ((nodes - 1) /
   (voxels - 1), 0 on a one-voxel axis). */
typedef struct VolclLightVolumeParams {
    volcl_uint dims[4];
    float toLight[4];
} VolclLightVolumeParams;

/* One slice of a light-volume sweep (cl/render/light_volume.cl): nodes of slice `slice` along `axis`, each
   stepping back toward the light to slice slice - dir (absent on the sweep's first slice). light: world
   direction toward a directional light, or a point light's world position (w: VOLCL_LIGHT_DIRECTIONAL or
   VOLCL_LIGHT_POINT). A point light is swept in up to six pyramids (one per axis and side); `cone` 1 keeps
   each node of the pyramid (plus `margin` world units) and stores only the nodes whose own pyramid this is. */
typedef struct VolclLightSweepParams {
    VolclGridParams grid;
    VolclLightVolumeParams lv;
    float light[4];
    float fromLight[4]; /* voxel coordinates per light-grid coordinate */
    float step;         /* integration step toward the light, world units */
    float margin;       /* cone: world distance kept outside the pyramid */
    volcl_uint knotCount, axis;
    int dir;                 /* +1: the light lies toward lower slices, -1: toward higher slices */
    volcl_uint slice, first; /* this slice; the sweep's first slice (no previous slice) */
    volcl_uint cone;         /* point-light pyramid sweep */
    volcl_uint lightOffset;  /* first node of this light in the volume */
    volcl_uint pad0, pad1, pad2;
} VolclLightSweepParams;

/* Everything a grid ray-marching frame needs besides buffers. */
/* A label map (LABELS, cl/common/labels.h): label voxel coordinates q = toLabel (p, 1) from the grid's voxel
   coordinates p (rows of a 3x4 matrix); dims: the label grid's nx, ny, nz and the table index meaning
   "outside the label grid" (unlabelled). */
typedef struct VolclLabelParams {
    float toLabel[3][4];
    volcl_uint dims[4];
} VolclLabelParams;

typedef struct VolclGridRenderParams {
    VolclCameraParams camera;
    VolclClipParams clip;
    VolclMarchParams march;
    VolclTfParams tf;
    VolclLightingParams lighting;
    VolclIsoParams iso;
    VolclGridParams grid;
    VolclFogParams fog;
    VolclLightVolumeParams lightVolume; /* SHADOW_VOLUME */
    VolclLabelParams labels;            /* LABELS */
} VolclGridRenderParams;

/* The path tracer's per-launch parameters (cl/render/pathtrace.cl): samples firstSample .. firstSample +
   sampleCount - 1 of every pixel are added to the accumulation buffer, whose mean (times invTotal) is the
   output. environment: rgb radiance of the uniform sky the paths see (w unused). emission: 1 adds the TF's
   emission c * tau, 0 leaves the medium purely scattering. maxBounces: scattering events per path. */
typedef struct VolclPathParams {
    volcl_uint seed, firstSample, sampleCount, maxBounces;
    float environment[4];
    float invTotal, emission, pad0, pad1;
} VolclPathParams;
/* A tetrahedral mesh in the renderer's normalised frame x' = (x - centre) / scale (so huge and tiny
   coordinates keep float precision); ray parameters t' = t / scale. */
typedef struct VolclMeshParams {
    float centre[4]; /* world centre of the mesh box */
    float boxLo[4];  /* normalised mesh box */
    float boxHi[4];
    float scale; /* world length of one normalised unit */
    float invScale;
    float epsilon;    /* normalised distance within which a re-entry counts as at the exit */
    float maxSegment; /* world length above which a segment is split for the 3D table (its last slice) */
    volcl_uint tetCount, boundaryFaces, bvhNodes, pad0;
} VolclMeshParams;

/* Everything a mesh cell-ray-casting frame needs besides buffers (camera, clip planes and point lights
   already in the normalised frame). */
typedef struct VolclMeshRenderParams {
    VolclCameraParams camera;
    VolclClipParams clip;
    VolclMarchParams march;
    VolclTfParams tf;
    VolclLightingParams lighting;
    VolclIsoParams iso;
    VolclMeshParams mesh;
} VolclMeshRenderParams;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VolclMeshParams) == 80, "VolclMeshParams layout must match OpenCL C");
static_assert(sizeof(VolclMeshRenderParams) == 80 + 144 + 16 + 32 + 176 + 96 + 80,
              "VolclMeshRenderParams layout must match OpenCL C");
static_assert(sizeof(VolclEllipsoid) == 64, "VolclEllipsoid layout must match OpenCL C");
static_assert(sizeof(VolclTfKnot) == 48, "VolclTfKnot layout must match OpenCL C");
static_assert(sizeof(VolclTfWidget) == sizeof(VolclTfKnot), "a VolclTfWidget fills one knot's record");
static_assert(sizeof(VolclCameraParams) == 80, "VolclCameraParams layout must match OpenCL C");
static_assert(sizeof(VolclClipParams) == 144, "VolclClipParams layout must match OpenCL C");
static_assert(sizeof(VolclMarchParams) == 16, "VolclMarchParams layout must match OpenCL C");
static_assert(sizeof(VolclTfParams) == 32, "VolclTfParams layout must match OpenCL C");
static_assert(sizeof(VolclLightingParams) == 176, "VolclLightingParams layout must match OpenCL C");
static_assert(sizeof(VolclIsoParams) == 96, "VolclIsoParams layout must match OpenCL C");
static_assert(sizeof(VolclPathParams) == 48, "VolclPathParams layout must match OpenCL C");
static_assert(sizeof(VolclGridParams) == 96, "VolclGridParams layout must match OpenCL C");
static_assert(sizeof(VolclFogParams) == 80, "VolclFogParams layout must match OpenCL C");
static_assert(sizeof(VolclLightVolumeParams) == 32, "VolclLightVolumeParams layout must match OpenCL C");
static_assert(sizeof(VolclLightSweepParams) == 96 + 32 + 32 + 48,
              "VolclLightSweepParams layout must match OpenCL C");
static_assert(sizeof(VolclLabelParams) == 64, "VolclLabelParams layout must match OpenCL C");
static_assert(sizeof(VolclGridRenderParams) == 80 + 144 + 16 + 32 + 176 + 96 + 96 + 80 + 32 + 64,
              "VolclGridRenderParams layout must match OpenCL C");
#endif

#endif
