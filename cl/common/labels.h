/* Label maps (LABELS 1 replace, 2 modulate, 3 alone): a sample's classification from the label voxels around it;
   render/grid/LabelField.cpp (classifyLabels) is the double reference. Table entry (r, g, b, w): w >= 0 a
   visible label's extinction per world unit (replace, alone) or opacity factor (modulate), -1 hidden, -2
   unlabelled (label 0, and the entry past the last label: outside the label grid). */
#ifndef VOLCL_LABELS_H
#define VOLCL_LABELS_H

/* The classification a label's table entry gives a sample whose TF classification is tf (rgb, tau). */
inline float4 label_class(float4 entry, float4 tf) {
    if (entry.w < -1.5f) {
#if LABELS == 3
        return (float4)(0.0f);
#else
        return tf;
#endif
    }
    if (entry.w < 0.0f) return (float4)(0.0f);
#if LABELS == 2
    return (float4)(tf.xyz * entry.xyz, tf.w * entry.w);
#else
    return entry;
#endif
}

/* The table index of label voxel c: its label, or the "outside" entry. */
inline uint label_at(__global const ushort* lv, const VolclLabelParams* L, int3 c) {
    if (c.x < 0 || c.y < 0 || c.z < 0 || c.x >= (int)L->dims[0] || c.y >= (int)L->dims[1] ||
        c.z >= (int)L->dims[2])
        return L->dims[3];
    return lv[((size_t)c.z * L->dims[1] + (size_t)c.y) * L->dims[0] + (size_t)c.x];
}

/* The sample at grid voxel point p classified by the labels (tf: the TF's classification there). Smooth: each
   label among the 8 label voxels around q adds g(I) = clamp(2 I - 1/2, 0, 1) of its extinction, I its trilinear
   indicator; the colour is that of the label with the largest indicator among those adding extinction. */
inline float4 label_sample(__global const ushort* lv, __global const float4* table, const VolclLabelParams* L,
                           float3 p, float4 tf) {
#ifdef LABEL_SAME_GRID
    const float3 q = p;
#else
    const float3 q =
        (float3)(dot(v3(L->toLabel[0]), p) + L->toLabel[0][3], dot(v3(L->toLabel[1]), p) + L->toLabel[1][3],
                 dot(v3(L->toLabel[2]), p) + L->toLabel[2][3]);
#endif
#ifdef LABEL_NEAREST
    return label_class(table[label_at(lv, L, convert_int3(floor(q + 0.5f)))], tf);
#else
    const float3 b = floor(q), f = q - b;
    const int3 c = convert_int3(b);
    uint l[8];
    float w[8];
    for (int i = 0; i < 8; ++i) {
        const int ox = i & 1, oy = (i >> 1) & 1, oz = i >> 2;
        l[i] = label_at(lv, L, c + (int3)(ox, oy, oz));
        w[i] = (ox ? f.x : 1.0f - f.x) * (oy ? f.y : 1.0f - f.y) * (oz ? f.z : 1.0f - f.z);
    }
    /* Inside one label (most samples): its classification whole, as the loop below would give it (indicator 1,
       g(1) = 1; a colour without extinction adds nothing). */
    if (l[1] == l[0] && l[2] == l[0] && l[3] == l[0] && l[4] == l[0] && l[5] == l[0] && l[6] == l[0] &&
        l[7] == l[0])
        return label_class(table[l[0]], tf);
    float tau = 0.0f, best = -1.0f;
    float3 rgb = (float3)(0.0f);
    for (int i = 0; i < 8; ++i) {
        bool counted = false;
        for (int j = 0; j < i; ++j)
            counted = counted || l[j] == l[i];
        if (counted) continue;
        float indicator = 0.0f;
        for (int j = i; j < 8; ++j)
            indicator += l[j] == l[i] ? w[j] : 0.0f;
        const float4 e = label_class(table[l[i]], tf);
        tau += clamp(2.0f * indicator - 0.5f, 0.0f, 1.0f) * e.w;
        if (e.w > 0.0f && indicator > best) {
            best = indicator;
            rgb = e.xyz;
        }
    }
    return (float4)(rgb, tau);
#endif
}

#endif
