"""Launch of the event-warping kernel: host arrays in, warped float coordinates out."""
import numpy as np
import warp as wp

from .event_warp import warp_events


def warp_to_reference(t, x, y, ref_index, ref_q, node_t, node_q, node_phi, camera_params,
                      undistort_iterations, device="cpu"):
    """Warped (x, y) float64 arrays; camera_params = (fx, fy, cx, cy, k1, k2)."""
    def arr(a, dtype, np_dtype=np.float64):
        return wp.array(np.ascontiguousarray(a, dtype=np_dtype), dtype=dtype, device=device)

    n = len(t)
    out_x = wp.empty(n, dtype=wp.float64, device=device)
    out_y = wp.empty(n, dtype=wp.float64, device=device)
    events = [arr(t, wp.float64), arr(x, wp.float64), arr(y, wp.float64),
              arr(ref_index, wp.int32, np.int32)]
    track = [arr(ref_q, wp.vec4d), arr(node_t, wp.float64), arr(node_q, wp.vec4d),
             arr(node_phi, wp.vec3d)]
    wp.launch(warp_events, n, device=device,
              inputs=[*events, *track, *map(float, camera_params), int(undistort_iterations),
                      out_x, out_y])
    return out_x.numpy(), out_y.numpy()
