// Motion vector of a surface point: pixels of a target of `target_size`, +y down, from this
// frame's position to the previous frame's (docs/dataset.md, Motion vectors).  Both positions
// are unjittered clip coordinates; a point at infinity (the sky) has w = -view z of its direction.
//
// A point that was not in front of the previous camera's near plane (previous clip z <= -w: behind
// the camera, on its plane or closer than near) had no position in the previous frame; dividing by
// its previous w mirrors it to the wrong side and grows without bound as w -> 0.  Such a point is
// disoccluded: its motion points off the previous frame, (width + height) pixels towards the side of
// the previous view axis the point lay on, so every consumer's off-screen test finds no history.
vec2 motion_to_previous(vec4 cur_clip, vec4 prev_clip, vec2 target_size) {
    if (prev_clip.z <= -prev_clip.w) {
        vec2 side = vec2(prev_clip.x, -prev_clip.y);
        float len = length(side);
        vec2 dir = len > 1e-12 ? side / len : vec2(1.0, 0.0);
        return dir * (target_size.x + target_size.y);
    }
    vec2 cur_ndc = cur_clip.xy / cur_clip.w;
    vec2 prev_ndc = prev_clip.xy / prev_clip.w;
    return (prev_ndc - cur_ndc) * vec2(0.5, -0.5) * target_size;
}
