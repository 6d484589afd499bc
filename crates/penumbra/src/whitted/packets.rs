//! The CPU renderer's fast path: where rays are coherent, MLRTA packets
//! (the multi-level ray tracing paper's tiles, entry points and 4x4
//! packets) trace them, and the twin (`Whitted::shade`) shades with their
//! hits. Primary rays share the eye; each point light's shadow rays of one
//! 16x16 tile share the light, so they are traced as packets from the
//! light towards the tile's lifted hit points, from one entry point per
//! tile and light. Secondary rays, directional lights' shadow rays and
//! shadow rays through glass are single rays, in the twin.
//!
//! The packets find exactly the hits single rays find (the kd-tree tests),
//! so the image equals the twin's pixel by pixel.

use glam::Vec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::geom::ray::{Hit, Ray};
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::frustum::Frustum;
use crate::mlrta::packet::PACKET;
use crate::mlrta::tiles::{DEFAULT_EP_BUDGET, Group, Rect, block_rects, pixels, search_below, trace_group};
use crate::mlrta::{MlrtaCounts, MlrtaSettings, Prepared, trace_image};
use crate::whitted::lights::DIRECTIONAL;
use crate::whitted::whitted::{Facing, FirstHit, Media, PixelOut, Whitted, pixel_ray};

/// Side of the tiles whose shadow rays share an entry point per light.
const SHADOW_TILE: u32 = 16;

/// Renders every pixel of `w.params` with packets (see the module's
/// description); MLRTA statistics of the primary and shadow packets.
pub fn render_packets(w: &Whitted, prepared: &Prepared, mlrta: &MlrtaSettings) -> Result<(Vec<PixelOut>, MlrtaCounts)> {
    let p = w.params;
    // The rows `first_pixel ..+ pixel_count` hold (the whole image, or a
    // band of it), traced as an image of their own: tiles and packets
    // group the rays, each pixel's answer is its own.
    if !p.first_pixel.is_multiple_of(p.width) || !p.pixel_count.is_multiple_of(p.width) {
        return Err(crate::error::Error::internal("packets render whole rows"));
    }
    let (first, rows) = (p.first_pixel, p.pixel_count / p.width);
    let n = p.pixel_count as usize;
    let media = Media::from_ids(&p.media[..p.media_len as usize]);
    let mut out = vec![PixelOut::default(); n];
    let mut sums = vec![Vec3::ZERO; n];
    let mut counts = MlrtaCounts::default();
    let tiles: Vec<Rect> = (0..rows)
        .step_by(SHADOW_TILE as usize)
        .flat_map(|y| {
            (0..p.width).step_by(SHADOW_TILE as usize).map(move |x| Rect {
                x,
                y,
                w: SHADOW_TILE.min(p.width - x),
                h: SHADOW_TILE.min(rows - y),
            })
        })
        .collect();
    let lights_inside: Vec<Option<u32>> = w
        .scene
        .lights
        .iter()
        .map(|l| {
            (l.kind != DIRECTIONAL)
                .then(|| prepared.inside_object(l.position()))
                .flatten()
        })
        .collect();
    for s in 0..p.spp {
        let rays: Vec<Ray> = (first..first + p.pixel_count)
            .into_par_iter()
            .map(|i| {
                let (o, d) = pixel_ray(p, i, s);
                Ray::new(o, d)
            })
            .collect();
        let image = trace_image(prepared, &rays, p.width, rows, mlrta, None)?;
        counts += image.counts;
        let shaded: Vec<(Rect, Vec<PixelOut>, MlrtaCounts)> = tiles
            .par_iter()
            .map(|&rect| {
                let mut c = MlrtaCounts::default();
                let pixels = shade_tile(w, prepared, rect, &rays, &image.hits, &lights_inside, media, &mut c);
                (rect, pixels, c)
            })
            .collect();
        for (rect, tile, c) in shaded {
            counts += c;
            for (k, i) in pixels(rect, p.width).enumerate() {
                let (px, o) = (&tile[k], &mut out[i as usize]);
                sums[i as usize] += Vec3::from_array(px.radiance);
                if s == 0 {
                    o.signature = px.signature;
                }
                for r in 0..4 {
                    o.rays[r] += px.rays[r];
                }
            }
        }
    }
    for (o, sum) in out.iter_mut().zip(sums) {
        o.radiance = (sum / p.spp as f32).to_array();
    }
    Ok((out, counts))
}

/// Shadow packets and shading of one tile's pixels (row-major in `rect`).
#[allow(clippy::too_many_arguments)]
fn shade_tile(
    w: &Whitted,
    prepared: &Prepared,
    rect: Rect,
    rays: &[Ray],
    hits: &[Hit],
    lights_inside: &[Option<u32>],
    media: Media,
    counts: &mut MlrtaCounts,
) -> Vec<PixelOut> {
    let p = w.params;
    let ids: Vec<u32> = pixels(rect, p.width).collect();
    let lights = p.light_count as usize;
    // Each pixel's primary hit (the packets' triangle or a nearer sphere).
    let found: Vec<Option<Facing>> = ids
        .iter()
        .map(|&i| {
            let r = &rays[i as usize];
            let (t, primitive) = w.closest(r.o(), r.d(), f32::INFINITY, Some(hits[i as usize]))?;
            Some(w.facing(r.o(), r.d(), t, primitive))
        })
        .collect();
    // Per pixel and light: whether triangles block its shadow ray (None:
    // left to the twin).
    let mut blocked = vec![None; ids.len() * lights];
    // Packets only where shadow rays stop at the first occluder.
    if p.transmissive == 0 {
        let lifted: Vec<Option<&Facing>> = found
            .iter()
            .map(|f| f.as_ref().filter(|f| w.scene.surface(f.hit.surface).lit()))
            .collect();
        for (j, light) in w.scene.lights[..lights].iter().enumerate() {
            if light.kind == DIRECTIONAL {
                continue;
            }
            // Each pixel's shadow ray towards this light, if it needs one.
            let target: Vec<Option<Vec3>> = lifted
                .iter()
                .map(|f| {
                    let f = (*f)?;
                    w.light_geometry(light, f.lifted, f.n_g, f.n_s).map(|g| g.dir)
                })
                .collect();
            let Some(frustum) = Frustum::new(light.position(), target.iter().flatten().copied(), 1.0) else {
                continue;
            };
            counts.ep_searches += 1;
            let start = search_below(
                prepared,
                &frustum,
                &EntryPoint::root(prepared),
                lights_inside[j],
                DEFAULT_EP_BUDGET,
                &mut counts.ep_steps,
            );
            for block in block_rects(rect) {
                let mut dirs = [Vec3::ZERO; PACKET];
                let mut slots = [0usize; PACKET];
                let mut m = 0;
                for i in pixels(block, p.width) {
                    let k = local(rect, i, p.width);
                    if let Some(d) = target[k] {
                        dirs[m] = d;
                        slots[m] = k;
                        m += 1;
                    }
                }
                if m == 0 {
                    continue;
                }
                let result = match &start {
                    None => [Hit::MISS; PACKET],
                    Some(entry) => {
                        let group = Group {
                            origin: light.position(),
                            dirs: &dirs[..m],
                            t_max: 1.0,
                            any_hit: true,
                        };
                        trace_group(prepared, &group, entry, None, counts)
                    }
                };
                for (r, &k) in result[..m].iter().zip(&slots[..m]) {
                    blocked[k * lights + j] = Some(r.is_hit());
                }
            }
        }
    }
    ids.iter()
        .enumerate()
        .map(|(k, &i)| {
            let r = &rays[i as usize];
            let first = FirstHit {
                facing: found[k],
                blocked: &blocked[k * lights..(k + 1) * lights],
            };
            let out = w.shade(r.o(), r.d(), media, Some(&first), None);
            PixelOut {
                radiance: out.radiance.to_array(),
                signature: out.signature,
                rays: out.rays,
            }
        })
        .collect()
}

/// Index of pixel `i` of a `width`-wide image in `rect`'s row-major order.
fn local(rect: Rect, i: u32, width: u32) -> usize {
    let (x, y) = (i % width, i / width);
    ((y - rect.y) * rect.w + (x - rect.x)) as usize
}
