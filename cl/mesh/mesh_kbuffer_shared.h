/* Parameters of a k-buffer (HAVS) mesh frame, shared by host C++ and OpenCL C (same layout on both sides). */
#ifndef VOLCL_MESH_KBUFFER_SHARED_H
#define VOLCL_MESH_KBUFFER_SHARED_H

#include "../volcl_shared.h"

/* Face flag bits (uint4::w of a face record). */
#define KB_FACE_BOUNDARY 1u
/* Fragment flag bits: a boundary face seen from outside (the ray enters the mesh) or from inside (it leaves). */
#define KB_FRAG_ENTER 1u
#define KB_FRAG_EXIT 2u

/* Geometry is in normalized mesh coordinates, (p - centre) / worldScale, so huge and tiny meshes keep the
   same float precision; ray distances are converted back to world lengths with worldScale. */
typedef struct VolclKBufferParams {
    float eye[4];     /* camera eye */
    float forward[4]; /* unit view direction f */
    float right[4];   /* unit r */
    float up[4];      /* unit u */
    float halfX,
        halfY; /* orthographic: half width and height of the view; perspective: tan of the half angles */
    float worldScale; /* world length of one normalized unit */
    float earlyTermination;
    volcl_uint width, height, perspective, faceCount; /* faceCount: faces drawn this frame (the LOD prefix) */
    volcl_uint tilesX, tilesY, pointCount, pad0;
    float tableScale;  /* (tf.tableSize - 1) / (tf.domainHi - tf.domainLo): table nodes per data unit */
    float lengthScale; /* tf.tableLengths / tf.tableMaxLength: length slices per world unit */
    float pad1, pad2;
    VolclTfParams tf;
} VolclKBufferParams;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VolclKBufferParams) == 64 + 16 + 16 + 16 + 16 + 32,
              "VolclKBufferParams layout must match OpenCL C");
#endif

#endif
