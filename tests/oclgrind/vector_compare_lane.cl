/* Oclgrind 21.10 bug reproducer: a bool from one lane of a vector compare is 255, not 1, at its default -Oz. */
/* At -Oz clang turns `s.x <= s.y` into a <2 x float> compare, a lane extract and a zext: Oclgrind then gives
   255 (the lane's all-ones), so `!found` stays true in mesh_cells' first_entry and faces are skipped. At -O0
   to -O3 and -Os the compare stays scalar and every out[i] is 1. */
float2 span(__global const float* in, int i) {
    return (float2)(in[2 * i], in[2 * i + 1]);
}
__kernel void vector_compare_lane(__global const float* in, __global int* out) {
    for (int i = 0; i < 4; ++i) {
        const float2 s = span(in, i);
        out[i] = s.x <= s.y;
    }
}
