//! Stiff regions, soft handles and symmetry in the editor: the rigidity brush and its colour
//! view, the active group's falloff, the symmetry toggles, mirrored painting and mirrored
//! posing. The equations are the solver's (`solver::deform::rig`, `solver::deform::symmetry`);
//! the mirror map (a plane fit and a kd-tree pass over the mesh) is computed on a worker
//! thread and polled here. Every edit goes through the undo history ([`EditState`]) and the
//! rig reaches the solver with the handles ([`EditorApp::rig`], `SolverCommand::SetScene`).

use std::ops::RangeInclusive;
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Weak};

use eframe::egui::{self, Key, Modifiers};
use solver::deform::rig::{Falloff, FalloffCurve, Rig};
use solver::deform::symmetry::{
    Axis, MirrorMap, SymmetryPlane, fit_plane, fit_plane_on, mirror_image, mirror_map,
    mirror_transform, partner_group,
};
use solver::geometry::embedding::{blend, closest_point_on_triangle};

use super::{EditorApp, Tool};
use crate::editor::undo::{EditState, GROUP_NAME_CHARS};

/// Which plane the mirror map is for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Request {
    /// The best fit over the three axes.
    Auto,
    /// The best offset along an axis the user chose.
    Axis(Axis),
    /// A plane as stored (a loaded scene, or a fit kept).
    Exact(SymmetryPlane),
}

/// The falloff radii the panel takes (fractions of the bounding-box diagonal): those a scene
/// accepts (`solver::animation::scene` refuses a radius outside [0, 1]), so that a scene's
/// radius can be typed again (up to 0.5, a scene's 0.8 showed and could not be).
const FALLOFF_RADII: RangeInclusive<f64> = 0.0..=1.0;

/// A mirror map for one mesh (identified by its `Arc`) and request.
struct Mirror {
    key: (usize, Request),
    plane: SymmetryPlane,
    error: f64,
    map: Arc<MirrorMap>,
}

/// Mirrored posing's partner of a group ([`EditorApp::mirror_partner`]), kept while the labels
/// and the mirror map it was found from stay: finding it walks every label, too much for every
/// frame of a pose drag (in the viewport, on the gizmo, on a pose panel number) on a dense mesh.
struct PosePartner {
    /// `color_version` (which every label change bumps), the labels' count and the group.
    key: (u64, usize, usize),
    /// The map it was found with; weak, so that a map replaced meanwhile is freed (its
    /// allocation, which this holds, is not reused for another map while held).
    map: Weak<MirrorMap>,
    partner: Option<usize>,
}

/// The rigging tools' UI state (not undoable: brush value, view toggle, the mirror map).
pub(super) struct Rigging {
    /// The rigidity the brush paints, in [0, 1].
    pub(super) value: f64,
    /// Show the rigidity map as colours (also while the rigidity brush is active).
    pub(super) show: bool,
    /// An axis chosen in the panel whose fitted plane is awaited.
    fit_axis: Option<Axis>,
    mirror: Option<Mirror>,
    job: Option<((usize, Request), Receiver<Mirror>)>,
    /// The mesh and request whose fit failed (its thread ended without a map): not tried
    /// again until either changes.
    failed: Option<(usize, Request)>,
    pose_partner: Option<PosePartner>,
    /// The partner group of the stroke in progress (mirrored painting of a handle group).
    pub(super) stroke_partner: Option<u32>,
    /// The falloff changed and the solvers have not been sent it yet (a slider drag rebuilds
    /// them once, when it ends).
    falloff_unsent: bool,
    /// Whether the last vertex colours showed the rigidity map.
    shown: bool,
}

impl Default for Rigging {
    fn default() -> Self {
        Rigging {
            value: 0.2,
            show: false,
            fit_axis: None,
            mirror: None,
            job: None,
            failed: None,
            pose_partner: None,
            stroke_partner: None,
            falloff_unsent: false,
            shown: false,
        }
    }
}

/// Soft (blue) to stiff (orange) for rigidity `r`.
fn rigidity_color(r: f64) -> [f32; 4] {
    let t = r.clamp(0.0, 1.0) as f32;
    let (soft, stiff) = ([0.15, 0.35, 1.0], [1.0, 0.45, 0.1]);
    let c = |k: usize| soft[k] + t * (stiff[k] - soft[k]);
    [c(0), c(1), c(2), 1.0]
}

impl EditorApp {
    /// The rig the solver gets with the handles: the rigidity map and each group's falloff.
    pub(super) fn rig(&self) -> Rig {
        let edit = &self.session.edit;
        Rig {
            rigidity: edit.rigidity.clone(),
            falloff: edit.groups.iter().map(|g| g.falloff).collect(),
        }
    }

    /// Whether `state` has another rig than the current one (the solver must rebuild).
    pub(super) fn rig_differs(&self, state: &EditState) -> bool {
        let falloffs = |s: &EditState| s.groups.iter().map(|g| g.falloff).collect::<Vec<_>>();
        state.rigidity != self.session.edit.rigidity
            || falloffs(state) != falloffs(&self.session.edit)
    }

    /// Forgets a mirror plane asked for by axis and not fitted yet: the state or the mesh it
    /// was asked for is gone (an undo, another mesh), and its fit would land in the next.
    pub(super) fn forget_axis_request(&mut self) {
        self.rigging.fit_axis = None;
    }

    /// Another mesh opened: the mirror map and its job go. They are keyed by the mesh's
    /// address, which a later mesh can be given once this one is freed: its partners would
    /// index past that mesh's vertices.
    pub(super) fn forget_mirror(&mut self) {
        self.rigging.mirror = None;
        self.rigging.job = None;
        self.rigging.failed = None;
    }

    fn mirror_request(&self) -> Request {
        match (self.rigging.fit_axis, self.session.edit.symmetry.plane) {
            (Some(a), _) => Request::Axis(a),
            (None, Some(p)) => Request::Exact(p),
            (None, None) => Request::Auto,
        }
    }

    /// Whether mirroring is on at all (painting or posing).
    fn mirror_wanted(&self) -> bool {
        let s = &self.session.edit.symmetry;
        s.mirror_painting || s.mirror_posing || self.rigging.fit_axis.is_some()
    }

    /// Starts the mirror map's job when the mesh or the plane changed, and takes its result.
    pub(super) fn poll_rigging(&mut self) {
        if self.showing_rigidity() != self.rigging.shown {
            self.rigging.shown = self.showing_rigidity();
            self.display.color_version += 1;
        }
        let Some(scene) = &self.session.scene else { return };
        let key = (Arc::as_ptr(&scene.mesh) as usize, self.mirror_request());
        let received = self.rigging.job.as_ref().map(|(k, rx)| (*k, rx.try_recv()));
        if let Some((k, Err(std::sync::mpsc::TryRecvError::Disconnected))) = received {
            // the thread ended without a map (it panicked): said, and not started again for
            // this mesh and plane (it said "fitting the plane…" for good)
            self.rigging.failed = Some(k);
            self.rigging.job = None;
            if k == key {
                self.error =
                    Some("the mirror plane could not be fitted (a bug: please report it)".into());
            }
        }
        if let Some((done, Ok(m))) = received {
            self.rigging.job = None;
            if done == key {
                if let Request::Axis(_) = done.1 {
                    self.rigging.fit_axis = None;
                    self.session.edit.symmetry.plane = Some(m.plane);
                    self.rigging.mirror =
                        Some(Mirror { key: (done.0, Request::Exact(m.plane)), ..m });
                } else {
                    self.rigging.mirror = Some(m);
                }
            }
        }
        let have = self.rigging.mirror.as_ref().is_some_and(|m| m.key == key);
        let running = self.rigging.job.as_ref().is_some_and(|(k, _)| *k == key);
        if have || running || !self.mirror_wanted() || self.rigging.failed == Some(key) {
            return;
        }
        let positions = scene.mesh.positions().to_vec();
        let (tx, rx) = channel();
        let request = key.1;
        std::thread::spawn(move || {
            let (plane, error) = match request {
                Request::Auto => fit_plane(&positions),
                Request::Axis(a) => fit_plane_on(&positions, a),
                Request::Exact(p) => (p, f64::NAN),
            };
            let map = mirror_map(&positions, &plane);
            let error = if error.is_nan() { map.mean_error } else { error };
            let _ = tx.send(Mirror { key, plane, error, map: Arc::new(map) });
        });
        self.rigging.job = Some((key, rx));
    }

    /// The mirror map for the current mesh and plane, once computed.
    pub fn mirror(&self) -> Option<(SymmetryPlane, &MirrorMap)> {
        let scene = self.session.scene.as_ref()?;
        let key = (Arc::as_ptr(&scene.mesh) as usize, self.mirror_request());
        self.rigging.mirror.as_ref().filter(|m| m.key == key).map(|m| (m.plane, &*m.map))
    }

    /// [`EditorApp::mirror`] with the map shared, so that the state can change meanwhile.
    fn mirror_shared(&self) -> Option<(SymmetryPlane, Arc<MirrorMap>)> {
        let scene = self.session.scene.as_ref()?;
        let key = (Arc::as_ptr(&scene.mesh) as usize, self.mirror_request());
        self.rigging.mirror.as_ref().filter(|m| m.key == key).map(|m| (m.plane, m.map.clone()))
    }

    /// The rigidity brush: footprint vertices (and their mirror partners when mirrored
    /// painting is on) set to the brush value, or back to 1 when erasing.
    pub(super) fn paint_rigidity(&mut self, erase: bool) {
        let Some(hover) = &self.interaction.hover else { return };
        let n = self.session.edit.labels.len();
        let mut vertices = hover.footprint.clone();
        if self.session.edit.symmetry.mirror_painting
            && let Some((_, map)) = self.mirror_shared()
        {
            let partners: Vec<u32> = vertices.iter().map(|&v| map.partner[v as usize]).collect();
            vertices.extend(partners);
        }
        let value = if erase { 1.0 } else { self.rigging.value.clamp(0.0, 1.0) };
        let r = self.session.edit.rigidity.get_or_insert_with(|| vec![1.0; n]);
        let mut changed = false;
        for v in vertices {
            if let Some(x) = r.get_mut(v as usize)
                && *x != value
            {
                *x = value;
                changed = true;
            }
        }
        if r.iter().all(|&x| x == 1.0) {
            self.session.edit.rigidity = None;
        }
        if changed {
            self.display.color_version += 1;
        }
    }

    /// Mirrored painting of a handle group: the footprint's mirror partners (outside the
    /// footprint) get the partner group, created as a pair on the stroke's first paint. A
    /// stroke whose first dab is centred on the plane (nearer to it than half the brush's
    /// radius, on the rest mesh), or that paints a group which is its own mirror image, paints
    /// a group on the midline: the partners join the group itself, as they do for a box or
    /// lasso across the plane. An erase of group `erased` frees the partners in it and in its
    /// mirror image (with `erased` `None`, in every group).
    pub(super) fn mirror_labels(
        &mut self,
        footprint: &[u32],
        group: Option<u32>,
        erased: Option<u32>,
    ) {
        if !self.session.edit.symmetry.mirror_painting {
            return;
        }
        let Some((plane, map)) = self.mirror_shared() else { return };
        let (partners, _) = partners_outside(&map, footprint);
        if partners.is_empty() {
            return;
        }
        let radius = f64::from(self.brush_world_radius());
        let on_plane = || self.dab_rest_center().is_some_and(|c| plane.distance(c) <= radius / 2.0);
        let target = match group {
            None => None,
            Some(g) => Some(match self.rigging.stroke_partner {
                Some(p) => p,
                None if on_plane() => {
                    self.rigging.stroke_partner = Some(g);
                    g
                }
                None => {
                    // the pair, or the group itself where it is its own mirror image
                    let found = mirror_image(&self.session.edit.labels, &map, g);
                    let p = found.unwrap_or_else(|| self.new_partner(g));
                    self.rigging.stroke_partner = Some(p);
                    p
                }
            }),
        };
        let from = match (group, erased) {
            (None, Some(g)) => self.erased_groups(g),
            _ => None,
        };
        for v in partners {
            let l = &mut self.session.edit.labels[v as usize];
            if from.is_none_or(|from| l.is_some_and(|k| from.contains(&k))) {
                *l = target;
            }
        }
        self.display.color_version += 1;
    }

    /// What an erase of group `g` frees under mirrored painting: `g` and its mirror image (found
    /// on the stroke's first dab and kept for the stroke), under the brush and at the partners
    /// alike, so that a stroke across the plane leaves the pair symmetric. `None` without
    /// mirrored painting or its map.
    pub(super) fn erased_groups(&mut self, g: u32) -> Option<[u32; 2]> {
        if let Some(p) = self.rigging.stroke_partner {
            return self.session.edit.symmetry.mirror_painting.then_some([g, p]);
        }
        let pair = self.mirror_pair(g)?;
        self.rigging.stroke_partner = Some(pair[1]);
        Some(pair)
    }

    /// `g` and its mirror image (`g` itself where it has none) under mirrored painting; `None`
    /// without mirrored painting or its map.
    pub(super) fn mirror_pair(&self, g: u32) -> Option<[u32; 2]> {
        if !self.session.edit.symmetry.mirror_painting {
            return None;
        }
        let (_, map) = self.mirror_shared()?;
        Some([g, mirror_image(&self.session.edit.labels, &map, g).unwrap_or(g)])
    }

    /// The centre of the brush's dab under the pointer on the rest mesh: the hit's barycentric
    /// weights on its displayed triangle, applied to the same triangle at rest.
    fn dab_rest_center(&self) -> Option<[f64; 3]> {
        let hover = self.interaction.hover.as_ref()?;
        let scene = self.session.scene.as_ref()?;
        let shown = self.display.viewports.get(hover.slot)?.positions()?;
        let tri = *scene.mesh.triangles().get(hover.hit.triangle as usize)?;
        let corner = |v: u32| shown.get(v as usize).map(|p| p.map(f64::from));
        let corners = [corner(tri[0])?, corner(tri[1])?, corner(tri[2])?];
        let (_, w) = closest_point_on_triangle(hover.hit.point.as_dvec3().to_array(), corners);
        Some(blend(scene.mesh.positions(), &tri, &w))
    }

    /// A new group paired with group `g`: named after it, with its falloff.
    fn new_partner(&mut self, g: u32) -> u32 {
        let edit = &mut self.session.edit;
        let (name, falloff) =
            (partner_name(&edit.groups[g as usize].name), edit.groups[g as usize].falloff);
        let k = edit.add_group();
        edit.groups[k].name = name;
        edit.groups[k].falloff = falloff;
        k as u32
    }

    /// What mirrored painting does with a box or lasso `region` about to be added to group `g`
    /// (`remove`: taken out of it), decided before it is: the region's partners outside it,
    /// and the group they join (or leave). That is `g` itself where the region crosses the
    /// plane (most of its partners inside it) or `g` is its own mirror image (a group on the
    /// midline), else `g`'s partner group; a region added with no partner group yet makes one
    /// (`None` here, [`Self::mirror_region`] creates it).
    pub(super) fn plan_mirror_region(
        &self,
        region: &[u32],
        g: u32,
    ) -> Option<(Vec<u32>, Option<u32>)> {
        if !self.session.edit.symmetry.mirror_painting {
            return None;
        }
        let (_, map) = self.mirror_shared()?;
        let (partners, inside) = partners_outside(&map, region);
        if partners.is_empty() {
            return None;
        }
        let target = if 2 * inside >= region.len() {
            Some(g)
        } else {
            mirror_image(&self.session.edit.labels, &map, g)
        };
        Some((partners, target))
    }

    /// The mirror partners of `region` outside it when painting is mirrored (else none).
    pub(super) fn mirrored_partners(&self, region: &[u32]) -> Vec<u32> {
        match self.session.edit.symmetry.mirror_painting {
            true => {
                self.mirror_shared().map_or(Vec::new(), |(_, map)| partners_outside(&map, region).0)
            }
            false => Vec::new(),
        }
    }

    /// Carries out [`Self::plan_mirror_region`]'s `plan` for group `g`: the partners join the
    /// plan's group, or, removing, leave the groups `freed` (`g` and its mirror image); whether a
    /// label changed.
    pub(super) fn mirror_region(
        &mut self,
        plan: (Vec<u32>, Option<u32>),
        g: u32,
        remove: Option<[u32; 2]>,
    ) -> bool {
        let (partners, target) = plan;
        let target = match (target, remove) {
            (_, Some(_)) => None,
            (Some(t), None) => Some(t),
            (None, None) => Some(self.new_partner(g)),
        };
        let mut changed = false;
        for v in partners {
            let l = &mut self.session.edit.labels[v as usize];
            let new = match remove {
                Some(freed) if l.is_some_and(|k| freed.contains(&k)) => None,
                Some(_) => *l,
                None => target,
            };
            changed |= new != *l;
            *l = new;
        }
        changed
    }

    /// Mirrored painting of a group command that made a group the vertices of `mask`: its
    /// partner group (`partner`, found before the command) becomes `mask`'s mirror image,
    /// among the vertices free or in it. Whether a label changed.
    pub(super) fn mirror_group_command(&mut self, partner: u32, mask: &[bool]) -> bool {
        let Some((_, map)) = self.mirror_shared() else { return false };
        let mut changed = false;
        for (v, l) in self.session.edit.labels.iter_mut().enumerate() {
            if *l != Some(partner) && l.is_some() {
                continue; // g's own and other groups' vertices stay
            }
            let new = mask.get(map.partner[v] as usize).is_some_and(|&m| m).then_some(partner);
            changed |= new != *l;
            *l = new;
        }
        changed
    }

    /// `g`'s partner group for a group command, found before it changes `g` (`None`: mirrored
    /// painting is off, the map is not ready, or `g` has no partner).
    pub(super) fn command_partner(&self, g: u32) -> Option<u32> {
        if !self.session.edit.symmetry.mirror_painting {
            return None;
        }
        let (_, map) = self.mirror_shared()?;
        partner_group(&self.session.edit.labels, &map, g)
    }

    /// Mirrored posing: the partner of `group` takes its pose mirrored across the plane.
    pub(super) fn mirror_pose(&mut self, group: usize) {
        let Some(p) = self.mirror_partner(group) else { return };
        let Some((plane, _)) = self.mirror_shared() else { return };
        let Some(pose) = self.session.edit.groups.get(group).map(|g| g.pose) else { return };
        let mirrored = mirror_transform(&plane, &pose);
        if let Some(g) = self.session.edit.groups.get_mut(p) {
            g.pose = mirrored;
        }
    }

    /// The group mirrored posing moves with `group`, while it is on. Found again only when
    /// the labels, the map or the group changed ([`PosePartner`]): once per pose drag, gizmo
    /// transform or panel number drag, not once per frame of it.
    pub(super) fn mirror_partner(&mut self, group: usize) -> Option<usize> {
        if !self.session.edit.symmetry.mirror_posing {
            return None;
        }
        let (_, map) = self.mirror_shared()?;
        let key = (self.display.color_version, self.session.edit.labels.len(), group);
        if let Some(kept) = &self.rigging.pose_partner
            && kept.key == key
            && Weak::as_ptr(&kept.map) == Arc::as_ptr(&map)
        {
            return kept.partner;
        }
        let partner =
            partner_group(&self.session.edit.labels, &map, group as u32).map(|p| p as usize);
        self.rigging.pose_partner = Some(PosePartner { key, map: Arc::downgrade(&map), partner });
        partner
    }

    /// Whether the rigidity map is drawn (the toggle, or the rigidity brush active).
    pub(super) fn showing_rigidity(&self) -> bool {
        self.rigging.show || self.interaction.tool == Tool::Rigidity
    }

    /// Paints the rigidity map into `colors` (soft blue to stiff orange).
    pub(super) fn rigidity_colors(&self, colors: &mut [[f32; 4]], over_texture: bool) {
        if !self.showing_rigidity() {
            return;
        }
        let r = self.session.edit.rigidity.as_deref();
        for (v, c) in colors.iter_mut().enumerate() {
            let mut rgba = rigidity_color(r.and_then(|r| r.get(v)).copied().unwrap_or(1.0));
            if over_texture {
                rgba[3] = 0.7;
            }
            *c = rgba;
        }
    }

    /// Shift+R: rigidity brush; M: mirrored painting; Shift+M: mirrored posing.
    pub(super) fn rigging_keys(&mut self, ctx: &egui::Context) {
        let consume = |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_key(m, k));
        if consume(Modifiers::SHIFT, Key::R) {
            self.interaction.tool = Tool::Rigidity;
            self.display.color_version += 1;
        }
        if consume(Modifiers::SHIFT, Key::M) {
            self.toggle_symmetry(|s| s.mirror_posing = !s.mirror_posing);
        }
        if consume(Modifiers::NONE, Key::M) {
            self.toggle_symmetry(|s| s.mirror_painting = !s.mirror_painting);
        }
    }

    fn toggle_symmetry(&mut self, f: impl FnOnce(&mut solver::animation::scene::SymmetrySpec)) {
        self.session.push_undo(self.session.edit.clone());
        f(&mut self.session.edit.symmetry);
    }

    /// The rigidity brush's settings, under the tool buttons.
    pub(super) fn rigidity_tool_panel(&mut self, ui: &mut egui::Ui) {
        if self.interaction.tool != Tool::Rigidity {
            return;
        }
        ui.add(
            egui::Slider::new(&mut self.interaction.brush_radius, 0.002..=0.5)
                .logarithmic(true)
                .text("brush radius"),
        );
        ui.add(egui::Slider::new(&mut self.rigging.value, 0.0..=1.0).text("rigidity"));
        ui.label("Left drag paints the rigidity (1 = plain ARAP, 0 = soft); Ctrl resets to 1.");
        let painted = self.session.edit.rigidity.is_some();
        let clear = ui.add_enabled(painted, egui::Button::new("Clear rigidity"));
        if clear.on_disabled_hover_text("no rigidity painted: 1 everywhere").clicked() {
            self.session.push_undo(self.session.edit.clone());
            self.session.edit.rigidity = None;
            self.display.color_version += 1;
            self.send_scene();
        }
    }

    /// The active group's falloff and the symmetry settings, below the group list.
    pub(super) fn rigging_panel(&mut self, ui: &mut egui::Ui) {
        self.poll_rigging();
        if let Some(k) =
            self.interaction.active_group.filter(|&k| k < self.session.edit.groups.len())
        {
            let mut f: Falloff = self.session.edit.groups[k].falloff;
            ui.label(format!("Soft falloff of {}", self.session.edit.groups[k].name));
            let slider = ui.add(
                egui::Slider::new(&mut f.radius, FALLOFF_RADII)
                    .clamping(egui::SliderClamping::Edits) // (none outside: a scene's are in it)
                    // a typed radius is one edit once entered: not a step and a rebuild of
                    // the solvers per keystroke ("0" on the way made the handle hard)
                    .update_while_editing(false)
                    .text("falloff radius")
                    .custom_formatter(
                        |r, _| if r == 0.0 { "hard".into() } else { format!("{r:.3}") },
                    ),
            );
            let mut curve_changed = false;
            ui.horizontal(|ui| {
                for c in FalloffCurve::ALL {
                    curve_changed |= ui.selectable_value(&mut f.curve, c, c.name()).changed();
                }
            });
            // One undo step per drag, none after an undo cancelled it (which sent the scene).
            if f != self.session.edit.groups[k].falloff {
                let pushed = self.session.push_for_drag(|s| s.edit.clone(), self.session.settings);
                if pushed {
                    self.session.edit.groups[k].falloff = f;
                }
                self.rigging.falloff_unsent = pushed;
            }
            if self.rigging.falloff_unsent && (curve_changed || !slider.dragged()) {
                self.rigging.falloff_unsent = false;
                self.send_scene();
            }
        }
        ui.horizontal(|ui| {
            let s = self.session.edit.symmetry;
            let mut paint = s.mirror_painting;
            let mut pose = s.mirror_posing;
            let hint = "brush strokes, boxes and lassos paint the mirrored vertices too, into \
                        the group's pair (the group itself for a stroke begun on the plane or a \
                        box or lasso across it); Grow, \
                        Shrink, Connected and Clear reshape the pair (Invert does not)";
            if ui.checkbox(&mut paint, "Mirror painting (M)").on_hover_text(hint).changed() {
                self.toggle_symmetry(|s| s.mirror_painting = paint);
            }
            if ui.checkbox(&mut pose, "Mirror posing (Shift+M)").changed() {
                self.toggle_symmetry(|s| s.mirror_posing = pose);
            }
        });
        ui.horizontal(|ui| {
            ui.label("Mirror plane:");
            let current =
                self.rigging.fit_axis.or(self.session.edit.symmetry.plane.map(|p| p.axis));
            if ui.selectable_label(current.is_none(), "Auto").clicked() && current.is_some() {
                self.rigging.fit_axis = None;
                if self.session.edit.symmetry.plane.is_some() {
                    self.toggle_symmetry(|s| s.plane = None);
                } else {
                    // an axis clicked, its fit not in yet: its step would undo nothing
                    let (edit, settings) = (&self.session.edit, self.session.settings);
                    self.session.history.drop_unchanged(edit, settings);
                }
            }
            for a in Axis::ALL {
                if ui.selectable_label(current == Some(a), a.name()).clicked() && current != Some(a)
                {
                    // one step for the plane the fit will set, not one per axis clicked
                    // before it is in
                    if self.rigging.fit_axis.is_none() {
                        self.session.push_undo(self.session.edit.clone());
                    }
                    self.rigging.fit_axis = Some(a);
                }
            }
        });
        ui.horizontal(|ui| {
            if ui
                .checkbox(&mut self.rigging.show, "Show rigidity")
                .on_hover_text("colour the mesh by rigidity: blue soft, orange stiff")
                .changed()
            {
                self.display.color_version += 1;
            }
            match self.mirror() {
                Some((p, _)) => {
                    let err = self.rigging.mirror.as_ref().map_or(0.0, |m| m.error);
                    ui.weak(format!("{} = {:.3}, error {:.1e}", p.axis.name(), p.offset, err))
                }
                None if self.mirror_wanted() && self.session.scene.is_none() => {
                    ui.weak("no mesh to mirror")
                }
                None if self.mirror_wanted() => ui.weak("fitting the plane…"),
                None => ui.weak(""),
            };
        });
        if self.rigging.job.is_some() {
            ui.ctx().request_repaint();
        }
    }
}

/// What tests and scripts read and set (beside `accessors`).
impl EditorApp {
    /// The rigidity map (`None`: 1 everywhere).
    pub fn rigidity(&self) -> Option<&[f64]> {
        self.session.edit.rigidity.as_deref()
    }

    /// The handle set the solvers get (labels with the rig), `None` without handles.
    pub fn solver_handles(&self) -> Option<solver::Handles> {
        self.handles()
    }

    /// The symmetry settings.
    pub fn symmetry(&self) -> solver::animation::scene::SymmetrySpec {
        self.session.edit.symmetry
    }

    /// The active tool.
    pub fn tool(&self) -> Tool {
        self.interaction.tool
    }

    /// The rigidity the brush paints, clamped to [0, 1]; NaN is refused (the value stays).
    pub fn set_rigidity_value(&mut self, value: f64) {
        if !value.is_nan() {
            self.rigging.value = value.clamp(0.0, 1.0);
        }
    }
}

/// The name of a group made as `name`'s mirror pair: "`name` mirror", cut to a group name's
/// length ([`GROUP_NAME_CHARS`]) as the rename field and the scene reader cut names.
fn partner_name(name: &str) -> String {
    format!("{name} mirror").chars().take(GROUP_NAME_CHARS).collect()
}

/// The mirror partners of `region` that are not in it (each once), and how many of the
/// region's partners are in it.
fn partners_outside(map: &MirrorMap, region: &[u32]) -> (Vec<u32>, usize) {
    let set: std::collections::HashSet<u32> = region.iter().copied().collect();
    let mut inside = 0;
    let mut outside = Vec::new();
    for &v in region {
        let p = map.partner[v as usize];
        if set.contains(&p) {
            inside += 1;
        } else {
            outside.push(p);
        }
    }
    outside.sort_unstable();
    outside.dedup();
    (outside, inside)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_pair_is_named_after_its_group_within_the_name_length() {
        assert_eq!(super::partner_name("Left arm"), "Left arm mirror");
        let long = "é".repeat(super::GROUP_NAME_CHARS);
        assert_eq!(super::partner_name(&long), long, "cut by characters, not bytes");
    }

    #[test]
    fn colours_run_from_soft_to_stiff() {
        let close = |a: [f32; 4], b: [f32; 4]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6);
        assert!(close(super::rigidity_color(0.0), [0.15, 0.35, 1.0, 1.0]));
        assert!(close(super::rigidity_color(1.0), [1.0, 0.45, 0.1, 1.0]));
        assert!(close(super::rigidity_color(7.0), super::rigidity_color(1.0)));
    }
}
