//! The zstd dictionary a format-5 header's JSON is coded against.
//!
//! A one-frame asset's header is about 1.1 kB of JSON, most of it key names and the bake's
//! settings, which every baked asset repeats; zstd alone codes it to about 0.6 kB. Coded
//! against a typical header (zstd's raw-content dictionary: the frame may copy from these
//! bytes as if they came before it), it takes 0.1–0.15 kB, and a sequence's header with a
//! record a frame shrinks by the same 0.45 kB. The dictionary is part of format 5: it must
//! never change, or the headers written with it would no longer read. It is the header of
//! a one-frame bake of the bundled sample with the defaults.

/// The header of a one-frame bake of `data/plume-a/vdb` (frame 21) with the defaults.
pub(crate) const HEADER_DICTIONARY: &[u8] = br#"{"generator":"haze 0.1.0","frame_count":1,"grid":{"dims":[48,48,64],"bbox_min":[0.0,0.0,0.0],"bbox_max":[3.0,3.0,4.0]},"source":{"path":"data/plume-a/vdb","grid":"density","frame_numbers":[21]},"settings":{"fit":{"frames":[{"frame":21,"hash_bytes":4161.204443686298,"quant_step":0.00784313678741455,"rbf_max_error":0.24412848055362701,"rbfs":300,"rel_l2":0.0806341556936288,"residual_bricks":179,"residual_nonzero":6461,"rms_over_max":0.010856347341728563}],"settings":{"options":{"delete":3,"fit":{"bounds":{"radius":[0.0,0.09],"weight":[0.01,1.0]},"coarse":"auto","max_iterations":1000,"optimizer":"lbfgsb","polish":{"max_iterations":100,"relative_reduction":0.0,"window":5,"window_gain":0.001},"seed":1,"stop":{"max_iterations":200,"relative_reduction":1e-6,"window":0,"window_gain":0.0},"teleport":true,"teleport_every":20},"insertion":"batch","marginal_gain":0.5,"max_insert":null,"max_rbfs":null,"rbfs":300,"threshold":1.1,"warm":{"max_iterations":200,"relative_reduction":0.0,"window":10,"window_gain":0.002}},"quant_bits":8,"rbfs":300,"residual_brick":4,"residual_error":0.00392156862745098,"search":null,"warm_up":0}}}}"#;
