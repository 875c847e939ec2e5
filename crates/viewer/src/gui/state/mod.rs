//! The app's state, apart from the drawing: what the panels share (the haptic loop's
//! backend, on its thread or stepped in place for tests; the running scene; the telemetry
//! history and the measurements; the link to a device; the replay), and the panels that keep
//! form state ([`super::panels`]: device, scene file, replay, material; the edit panel's
//! [`EditState`]). Everything the panels show is read from here, and everything they do goes
//! through its methods, so a test drives the app by calling them, without a window.

use std::path::Path;
use std::sync::atomic::Ordering;

use device::safety::Faults;
use friction::FrictionMaterial;
use nurbs::Vec2;

use super::editing::EditState;
use super::moving_shape::DeformState;
use super::panels::{DevicePanel, FilePanel, MaterialPanel, ReplayPanel};
use super::replay::Replay;
use super::surface_scene::SpatialState;
use super::telemetry::Telemetry;
use host::backend::{Backend, LinkEvent, LoopCommand, Reply, Sample};
use host::devices::{self, Target};
use host::error::MaterialChangeError;
use host::planar::{HapticLoop, PlanarSession, START_HIP};
use host::runlog::RecordTx;
use scene::bundled::BUNDLED;
use scene::{Material, Scene, Space};

pub use super::reach::Reach;
pub use super::scene_view::{CURVE_SAMPLES, ObjectView, SceneView};
pub use super::telemetry::{FRAME_WINDOW, HISTORY_S, JITTER_WINDOW};

mod editing;

/// Which device the app drives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The simulated pantograph in this process (the loop on the app's own thread).
    Simulated,
    /// A device behind a link ([`host::remote`]): its name (`tcp 127.0.0.1:7000`, …).
    Linked(String),
}

/// The link to a device, as the app last heard of it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinkState {
    /// The device's hello, once it answered.
    pub hello: Option<protocol::Hello>,
    /// Whether its plant is simulated (the mouse moves its virtual hand).
    pub simulated_plant: bool,
    /// Its newest status.
    pub status: Option<protocol::Status>,
    /// Why the link is gone, once it is.
    pub lost: Option<String>,
    /// The newest refusal (a command the device nacked), as a message.
    pub refused: Option<String>,
}

/// A scene sent to the loop, shown once the loop (or the device) took it.
#[derive(Debug)]
struct PendingScene {
    view: SceneView,
    material: Option<FrictionMaterial>,
    /// An edit of the running scene (the edit history and the material editor stay).
    edited: bool,
    /// The spatial hand of a scene without planar objects.
    spatial: Option<SpatialState>,
}

/// The whole state of the app.
#[derive(Debug)]
pub struct AppState {
    /// The planar loop: on its thread (the simulator, or the host of a device behind a link),
    /// stepped in place (tests: one tick per [`AppState::step`]), or stopped
    /// ([`AppState::shutdown`]).
    backend: Backend<HapticLoop>,
    /// The device the app drives.
    pub device: DeviceChoice,
    /// The link to it (default for the simulated one).
    pub link: LinkState,
    /// A scene sent to a threaded loop, shown once the loop (or the device) took it.
    pending: Option<PendingScene>,
    /// The run log being replayed, if one is: the views and plots show it instead of the
    /// live loop.
    pub replay: Option<Replay>,
    /// The recorder's input, handed to every loop the app starts.
    record: Option<RecordTx>,
    /// The scene being rendered.
    pub scene: SceneView,
    /// The simulated device's description (a `device/1` file's, or the default).
    pub spec: device::spec::DeviceSpec,
    /// The device's reach.
    pub reach: Reach,
    /// The telemetry: the last [`HISTORY_S`] seconds of samples (the live loop's, or the
    /// replay's), the mode switches, the tick and frame statistics.
    pub telemetry: Telemetry,
    /// The material the loop renders.
    pub running_material: Option<FrictionMaterial>,
    /// The hand's target as last set (m).
    pub hand_target: Vec2,
    /// Who holds the simulated handle, as last set.
    pub hand: host::hand::Hand,
    /// Whether the user is dragging the hand.
    pub dragging: bool,
    /// Why the loop did not take the last command ([`AppState::refusal`]).
    refusal: Option<&'static str>,
    /// Forces on, as last asked.
    pub forces_requested: bool,
    /// Faults still latched after the last clear, if one was asked for.
    pub faults_after_clear: Option<Faults>,
    /// A command the loop answered it does not support ([`Reply::Unsupported`]); the app
    /// sends none, so this shows a bug.
    pub loop_refused: Option<String>,
    /// The device panel: the fields naming a link.
    pub device_panel: DevicePanel,
    /// The scene panel: the file path, why the last scene was refused, where it was saved.
    pub files: FilePanel,
    /// The replay panel: the run log's path, why the last one could not be replayed.
    pub replay_panel: ReplayPanel,
    /// The material panel: the editor's values, why they were refused.
    pub materials: MaterialPanel,
    /// The edit panel and the 2-D view's editing: selection, drag, undo history.
    pub edit: EditState,
    /// The 3-D view and the spatial hand, for a scene without planar objects (or an opened
    /// mesh); while it is there the telemetry is the spatial loop's.
    pub spatial: Option<SpatialState>,
    /// The *deform* switch of the object felt and its moving shape.
    pub deform: DeformState,
    /// While `Some`, every tick the UI takes in from the live loop is kept here too (the
    /// participant screen's per-trial run logs, [`super::participant`]); its owner empties
    /// it.
    pub capture: Option<Vec<host::tick::Tick>>,
}

impl AppState {
    /// The app on the bundled scene `name` (or on `scene`), with the loop on its thread
    /// (`threaded`) or stepped in place, recording to `record` when given.
    pub fn new(
        label: &str,
        scene: Scene,
        threaded: bool,
        record: Option<RecordTx>,
    ) -> anyhow::Result<Self> {
        Self::on(
            device::spec::DeviceSpec::default(),
            label,
            scene,
            threaded,
            record,
        )
    }

    /// [`AppState::new`] with the simulated device described by `spec` (a `device/1`
    /// file's): its arm, controller and reach.
    pub fn on(
        spec: device::spec::DeviceSpec,
        label: &str,
        scene: Scene,
        threaded: bool,
        record: Option<RecordTx>,
    ) -> anyhow::Result<Self> {
        let session = PlanarSession::new_on(spec, scene.clone())?;
        let view = SceneView::new(label, &scene, session.object());
        let haptic = HapticLoop::new(session, START_HIP)?;
        let spatial = if view.is_planar() {
            None
        } else {
            Some(SpatialState::of_scene(
                label,
                &scene,
                None,
                threaded,
                record.as_ref().map(|r| r.for_space(Space::Spatial)),
            )?)
        };
        let running_material = haptic
            .material()
            .or_else(|| spatial.as_ref().and_then(SpatialState::material));
        let backend = Backend::start(haptic, threaded, record.clone())?;
        let mut deform = DeformState::default();
        let felt = view
            .rendered
            .or_else(|| spatial.as_ref().and_then(SpatialState::object));
        deform.scene_shown(&scene, felt);
        Ok(AppState {
            backend,
            device: DeviceChoice::Simulated,
            hand: host::hand::Hand::Grip,
            link: LinkState::default(),
            pending: None,
            replay: None,
            record,
            scene: view,
            spec,
            reach: Reach::of_device(&spec),
            telemetry: Telemetry::default(),
            running_material,
            hand_target: START_HIP,
            dragging: false,
            refusal: None,
            forces_requested: true,
            faults_after_clear: None,
            loop_refused: None,
            device_panel: DevicePanel::default(),
            files: FilePanel::default(),
            replay_panel: ReplayPanel::default(),
            materials: MaterialPanel::new(running_material),
            edit: EditState::default(),
            spatial,
            deform,
            capture: None,
        })
    }

    /// The app on the bundled scene `name`, stepped in place (for tests).
    pub fn stepped(name: &str) -> anyhow::Result<Self> {
        let bundled = BUNDLED
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| anyhow::anyhow!("no bundled scene {name:?}"))?;
        let scene = Scene::from_json_str(bundled.json)?;
        Self::new(bundled.name, scene, false, None)
    }

    /// Whether the loop runs on its own thread (real time).
    pub fn is_threaded(&self) -> bool {
        self.backend.is_threaded()
    }

    /// Gives `command` to the planar loop (a stepped loop's reply is taken in at once);
    /// false when it was dropped ([`AppState::refusal`] says why).
    pub(super) fn command(&mut self, command: LoopCommand) -> bool {
        let sent = self.backend.command(command);
        self.refusal = sent.refusal();
        if let Some(reply) = sent.reply() {
            self.on_reply(reply);
        }
        self.refusal.is_none()
    }

    /// Why the loop did not take the last command: "its queue is full", or "it is not
    /// running" (a lost link), for the message that says so.
    pub fn refusal(&self) -> &'static str {
        self.refusal.unwrap_or("it refused it")
    }

    /// Runs `n` ticks of a stepped loop (nothing for a threaded one), then takes in their
    /// telemetry as [`AppState::poll`] does.
    pub fn step(&mut self, n: usize) {
        if let Some(spatial) = &mut self.spatial {
            for s in spatial.step(n) {
                self.take(s);
            }
        } else {
            for s in self.backend.step(n) {
                self.take(s);
            }
        }
        self.refresh_deform();
    }

    /// Takes in what the loop sent since the last call (never waits).
    pub fn poll(&mut self) {
        let (mut samples, mut replies) = self.backend.drain();
        if let Some(spatial) = &self.spatial {
            // The planar loop renders nothing meanwhile: its ticks are not shown.
            let (spatial_samples, spatial_replies) = spatial.drain();
            samples = spatial_samples;
            replies.extend(spatial_replies);
        }
        for s in samples {
            self.take(s);
        }
        for r in replies {
            self.on_reply(r);
        }
        self.refresh_deform();
    }

    /// Makes the object felt deformable (`true`) or rigid at rest again: the command goes to
    /// the loop that renders it (the planar device's or the spatial hand's); the loop's answer
    /// sets [`DeformState::deforming`], or [`DeformState::error`] says why not.
    pub fn set_deform(&mut self, on: bool) {
        if on && self.deform.info.is_none() {
            self.deform.error = Some(
                "the object felt is rigid: give it a \"dynamics\" block in the scene file to \
                 make it deformable"
                    .into(),
            );
            return;
        }
        self.deform.requested = on;
        self.deform.error = None;
        self.send_deform(on);
    }

    fn send_deform(&mut self, on: bool) {
        if let Some(spatial) = self.spatial.as_mut().filter(|s| s.has_loop()) {
            if let Some(reply) = spatial.deform(on) {
                self.on_reply(reply);
            }
        } else if !self.command(LoopCommand::Deform(on)) {
            self.deform.error = Some(format!(
                "the haptic loop did not take it: {}",
                self.refusal()
            ));
            self.deform.refused();
        }
    }

    /// Reads the moving shape the loop published, and hands it to the 3-D view.
    fn refresh_deform(&mut self) {
        let changed = self.deform.refresh();
        if let Some(spatial) = &mut self.spatial
            && (changed || (self.deform.moving.is_none() && spatial.view.is_moving()))
        {
            spatial.view.set_moving(self.deform.moving_object());
        }
    }

    fn take(&mut self, s: Sample) {
        // The ticks come from the spatial hand's loop or the planar device's: on a change of
        // loop the history is another clock's (the 3-D plots lost their time axis after a
        // 2-D scene).
        let spatial_loop = self.spatial.is_some();
        if self.telemetry.spatial_source != Some(spatial_loop) {
            self.telemetry.restart();
            self.telemetry.spatial_source = Some(spatial_loop);
        }
        self.telemetry.received += 1;
        if let Some(capture) = &mut self.capture {
            capture.push(s.tick);
        }
        if self.replay.is_some() {
            // The live loop runs on behind a replay; its ticks are not shown.
            return;
        }
        self.telemetry.take(s);
    }

    fn on_reply(&mut self, reply: Reply) {
        match reply {
            Reply::Material(Ok(m)) => {
                self.running_material = Some(m);
                self.materials.error = None;
            }
            Reply::Material(Err(e)) => self.materials.error = Some(e.to_string()),
            Reply::Swapped => {
                if let Some(p) = self.pending.take() {
                    self.show_scene(p);
                }
            }
            Reply::FaultsCleared(f) => self.faults_after_clear = Some(f),
            Reply::Mesh(Ok(())) => {}
            Reply::Mesh(Err(e)) => {
                if let Some(spatial) = &mut self.spatial {
                    spatial.message = Some(format!("{e}; the hand still feels the NURBS surface"));
                }
            }
            Reply::Deform(r) => {
                self.deform.on_reply(r);
                self.refresh_deform();
            }
            Reply::Unsupported(what)
                if what == LoopCommand::<PlanarSession>::Deform(true).name() =>
            {
                self.deform.error = Some(format!("this device does not support {what}"));
                self.deform.refused();
                self.refresh_deform();
            }
            Reply::Unsupported(what) => {
                self.loop_refused = Some(format!("the haptic loop does not support {what}"));
            }
            Reply::Link(event) => self.on_link(event),
        }
    }

    fn on_link(&mut self, event: LinkEvent) {
        match event {
            LinkEvent::Connected {
                hello,
                simulated_plant,
                ..
            } => {
                self.link.hello = Some(hello);
                self.link.simulated_plant = simulated_plant;
            }
            LinkEvent::Status(s) => self.link.status = Some(s),
            LinkEvent::Refused { what, reason } => {
                let message = format!("the device refused {what}: {reason}");
                if what == "the scene upload"
                    && let Some(p) = self.pending.take()
                {
                    self.files.error = Some(format!(
                        "{}: {message}; the running scene is unchanged",
                        p.view.label
                    ));
                }
                self.link.refused = Some(message);
            }
            LinkEvent::Lost(reason) => {
                self.link.lost = Some(reason);
                self.forces_requested = false;
                self.pending = None;
            }
        }
    }

    fn show_scene(&mut self, p: PendingScene) {
        self.spatial = p.spatial;
        self.scene = p.view;
        self.files.error = None;
        self.running_material = p.material;
        if p.edited {
            self.edit.keep_valid_selection(&self.scene.model);
        } else {
            self.edit.reset();
            self.materials.edited = p.material.unwrap_or_default();
            self.materials.error = None;
            self.telemetry.scene_opened();
        }
        // The loop renders the new object rigid, at rest: ask again when it deforms too.
        let felt = self.felt_object();
        if self.deform.scene_shown(&self.scene.model, felt) {
            self.send_deform(true);
        }
    }

    /// Drives the device `target` instead of the one now driven: the link opens on its own
    /// thread (the UI never waits for it); once the device answers, the running scene is
    /// uploaded to it, and a device with a simulated plant (the host's simulator, the
    /// firmware under QEMU) has its faults cleared, is calibrated and has its forces
    /// enabled. A board waits for Calibrate and the forces switch. `Target::Sim` here is
    /// the host's simulated device behind the protocol ([`protocol::host_side::SimLink`]).
    pub fn connect(&mut self, target: Target) {
        let setup = !matches!(target, Target::Hid | Target::Serial(_));
        self.connect_with(describe(&target), move || devices::open(&target), setup);
    }

    /// [`AppState::connect`] with the link opened by `open` (tests wrap a link in one they
    /// can cut); `setup` as for a simulated plant.
    pub fn connect_with(
        &mut self,
        device: String,
        open: impl FnOnce() -> Result<devices::Opened, protocol::host_side::LinkError> + Send + 'static,
        setup: bool,
    ) {
        match host::remote::spawn(device.clone(), open, setup, self.record.clone()) {
            Ok(thread) => {
                // The device's host takes the planar loop's commands: the same backend.
                self.backend = Backend::Thread(thread);
                self.device = DeviceChoice::Linked(device);
                self.link = LinkState::default();
                self.forget_errors();
                self.forces_requested = setup;
                // The virtual hand of a simulated plant goes where the app's hand is.
                self.command(LoopCommand::hand_to(self.hand_target.extend(0.0)));
                self.telemetry.restart();
                let scene = self.scene.model.clone();
                let label = self.scene.label.clone();
                self.open_scene(&label, scene);
            }
            Err(e) => self.link.lost = Some(format!("cannot start the link's thread: {e}")),
        }
    }

    /// Forgets the messages of the loop that was (another loop starts: a device switch), so
    /// that no banner of the old one (a "not running" after its link was lost) stays.
    fn forget_errors(&mut self) {
        self.refusal = None;
        self.materials.error = None;
        self.deform.error = None;
        self.files.error = None;
        if let Some(spatial) = &mut self.spatial {
            spatial.message = None;
        }
    }

    /// Drives the simulated pantograph in this process again, on the running scene.
    pub fn use_simulated(&mut self) {
        let rebuilt = PlanarSession::new_on(self.spec, self.scene.model.clone())
            .map_err(anyhow::Error::from)
            .and_then(|s| Ok(HapticLoop::new(s, START_HIP)?))
            .and_then(|h| Ok(Backend::start(h, true, self.record.clone())?));
        match rebuilt {
            Ok(backend) => {
                self.backend = backend;
                self.device = DeviceChoice::Simulated;
                self.hand = host::hand::Hand::Grip;
                self.link = LinkState::default();
                self.forget_errors();
                self.forces_requested = true;
                self.telemetry.restart();
                let felt = self.felt_object();
                if self.spatial.is_none() && self.deform.scene_shown(&self.scene.model, felt) {
                    self.send_deform(true);
                }
            }
            Err(e) => self.files.error = Some(format!("cannot restart the simulator: {e}")),
        }
    }

    /// Whether the device's forces are on as far as the app knows: the simulator's switch,
    /// or the linked device's newest status while its link is up (a lost link counts as
    /// off: the device's watchdog turns them off).
    pub fn forces_on(&self) -> bool {
        match &self.device {
            DeviceChoice::Simulated => self.latest().is_some_and(|s| s.forces_enabled),
            DeviceChoice::Linked(_) => {
                self.link.lost.is_none() && self.link.status.is_some_and(|s| s.forces_enabled)
            }
        }
    }

    /// The link's quality: frames lost and corrupt on the way, and the newest heartbeat's
    /// round trip (µs); `None` for the simulator in the app.
    pub fn link_quality(&self) -> Option<(u64, u64, u64)> {
        match (&self.device, self.backend.counters()) {
            (DeviceChoice::Linked(_), Some(c)) => Some((
                c.link_lost_frames.load(Ordering::Relaxed),
                c.link_bad_frames.load(Ordering::Relaxed),
                c.link_rtt_us.load(Ordering::Relaxed),
            )),
            _ => None,
        }
    }

    /// The CRC-32 of the scene the device has active: the simulator's own receiver's in the
    /// app, the newest status's for a device behind a link; `None` before there is one.
    pub fn device_scene_crc32(&self) -> Option<u32> {
        match (&self.device, self.backend.stepped()) {
            (DeviceChoice::Simulated, Some(h)) => h.session().scene_crc32(),
            (DeviceChoice::Linked(_), _) => self.link.status.map(|s| s.scene_crc32),
            // The threaded simulator's session lives on its thread; the scene it took is
            // the one shown.
            (DeviceChoice::Simulated, _) => self
                .scene
                .rendered
                .and_then(|i| host::upload::wire_scene(&self.scene.model, i).ok())
                .map(|w| protocol::crc32(&w)),
        }
    }

    /// Calibrates the device (a board must sit at its end stops).
    pub fn calibrate(&mut self) {
        self.command(LoopCommand::Calibrate);
    }

    /// Who holds the simulated pantograph's handle: a grip, a light fingertip, or nobody
    /// (released: the handle goes on under its own mass, the device's friction and the
    /// rendered force). The simulated device in the app only; a board's handle is in a
    /// person's hand.
    pub fn set_hand(&mut self, hand: host::hand::Hand) {
        if self.device == DeviceChoice::Simulated {
            self.hand = hand;
            self.command(LoopCommand::Hand(hand));
        }
    }

    /// What the 2-D view says while nobody holds the simulated handle: a drag then moves only
    /// the hand's target, and the handle stays where its own mass and the device's friction
    /// leave it. `None` while a hand holds it (or on a linked device).
    pub fn hand_hint(&self) -> Option<&'static str> {
        (self.device == DeviceChoice::Simulated && self.hand == host::hand::Hand::Released)
            .then_some(
                "Hand released: nobody holds the handle, so dragging moves only the hand's target. \
             Choose grip or fingertip under Device to move it.",
            )
    }

    /// Replays the run log at `path` in the views and plots (the live loop runs on behind
    /// it, unseen); an unreadable or invalid log leaves everything as it was and
    /// [`ReplayPanel::error`] names the line at fault.
    pub fn open_replay(&mut self, path: &Path) {
        match Replay::open(path) {
            Ok(r) => {
                self.replay = Some(r);
                self.replay_panel.error = None;
                self.refresh_replay();
            }
            Err(e) => self.replay_panel.error = Some(e.to_string()),
        }
    }

    /// Back to the live loop.
    pub fn close_replay(&mut self) {
        self.replay = None;
        self.telemetry.clear_history();
    }

    /// Moves the replay's cursor to `t_s` (s, the log's time).
    pub fn seek_replay(&mut self, t_s: f64) {
        if let Some(r) = &mut self.replay {
            r.seek(t_s);
            self.refresh_replay();
        }
    }

    /// Plays or pauses the replay at `speed` (× real time) and moves its cursor to `cursor_s`
    /// when that differs from where it is (the replay panel's controls).
    pub fn steer_replay(&mut self, playing: bool, speed: f64, cursor_s: f64) {
        let Some(r) = &mut self.replay else {
            return;
        };
        r.playing = playing;
        r.speed = speed;
        if r.cursor() != cursor_s {
            self.seek_replay(cursor_s);
        }
    }

    /// Advances a playing replay by `wall_s` of real time (the app calls it every frame).
    pub fn advance_replay(&mut self, wall_s: f64) {
        if let Some(r) = &mut self.replay
            && r.playing
        {
            r.advance(wall_s);
            self.refresh_replay();
        }
    }

    fn refresh_replay(&mut self) {
        let Some(r) = self.replay.take() else {
            return;
        };
        self.telemetry.clear_history();
        for s in r.window() {
            self.telemetry.push(s);
        }
        self.replay = Some(r);
    }

    /// The newest sample.
    pub fn latest(&self) -> Option<&Sample> {
        self.telemetry.latest()
    }

    /// The latched faults in the newest sample.
    pub fn faults(&self) -> Faults {
        Faults::from_bits_truncate(
            self.latest()
                .and_then(|s| s.tick.device)
                .map_or(0, |d| d.faults),
        )
    }

    /// Moves the hand's target to `target` (m) when the device reaches it; a target out of
    /// reach leaves the hand where it was (returns false).
    pub fn set_hand_target(&mut self, target: Vec2) -> bool {
        self.glide_hand_to(target, 0.0)
    }

    /// As [`AppState::set_hand_target`], the hand getting there `over_s` seconds from now at a
    /// steady speed: the pointer's own pace ([`LoopCommand::HandTarget`]).
    pub fn glide_hand_to(&mut self, target: Vec2, over_s: f32) -> bool {
        if self.replay.is_some() || !self.reach.contains(target) {
            return false;
        }
        self.hand_target = target;
        self.command(LoopCommand::HandTarget {
            to: target.extend(0.0),
            over_s,
        })
    }

    /// Applies the material editor's values: validated field by field here (the message names
    /// the field), then by the device's controller in the loop. On error the running material
    /// stays and [`MaterialPanel::error`] says why.
    pub fn apply_material(&mut self) {
        let m = self.materials.edited;
        if let Err(e) = Material::from_friction(m) {
            self.materials.error = Some(MaterialChangeError::Invalid(e).to_string());
            return;
        }
        if let Some(spatial) = self.spatial.as_mut().filter(|s| s.has_loop()) {
            if let Some(reply) = spatial.set_material(m) {
                self.on_reply(reply);
            }
            return;
        }
        if self.scene.rendered.is_none() {
            self.materials.error = Some(MaterialChangeError::NoObject.to_string());
            return;
        }
        if !self.command(LoopCommand::SetMaterial(m)) {
            self.materials.error = Some(format!(
                "the haptic loop did not take the material: {}",
                self.refusal()
            ));
        }
    }

    /// Resets the editor to the running material.
    pub fn revert_material(&mut self) {
        if let Some(m) = self.running_material {
            self.materials.edited = m;
        }
        self.materials.error = None;
    }

    /// Opens the bundled scene `name`.
    pub fn open_bundled(&mut self, name: &str) {
        match BUNDLED.iter().find(|b| b.name == name) {
            Some(b) => self.open_text(b.name, b.json),
            None => self.files.error = Some(format!("no bundled scene {name:?}")),
        }
    }

    /// Opens the scene file at `path`.
    pub fn open_path(&mut self, path: &Path) {
        match Scene::load(path) {
            Ok(scene) => self.open_scene(&path.display().to_string(), scene),
            Err(e) => self.files.error = Some(format!("{e}; the running scene is unchanged")),
        }
    }

    /// Opens a scene from its JSON text, labelled `label`.
    pub fn open_text(&mut self, label: &str, json: &str) {
        match Scene::from_json_str(json) {
            Ok(scene) => self.open_scene(label, scene),
            Err(e) => {
                self.files.error = Some(format!("{label}: {e}; the running scene is unchanged"));
            }
        }
    }

    /// Renders object `index` of the running scene instead of the one now felt: a planar
    /// object on the device (the 2-D view), a spatial one with surfaces through the spatial
    /// hand (the 3-D view, the planar device idle).
    pub fn render_object(&mut self, index: usize) {
        let label = self.scene.label.clone();
        self.open_scene_object(&label, self.scene.model.clone(), Some(index));
    }

    /// The index of the scene's object the user feels: the planar one the device renders,
    /// or the surface object the spatial hand feels in the 3-D view.
    pub fn felt_object(&self) -> Option<usize> {
        self.scene
            .rendered
            .or_else(|| self.spatial.as_ref().and_then(SpatialState::object))
    }

    /// Renders `scene` from the next tick when the device accepts it; otherwise the running
    /// scene stays and [`FilePanel::error`] says why.
    pub fn open_scene(&mut self, label: &str, scene: Scene) {
        self.open_scene_object(label, scene, None);
    }

    /// [`AppState::open_scene`] rendering object `object` (the first planar one when `None`).
    fn open_scene_object(&mut self, label: &str, scene: Scene, object: Option<usize>) {
        if let Err(e) = self.swap(label, scene, object, false) {
            self.files.error = Some(e);
        }
    }

    /// Sends `scene` (rendering `object`, the first planar one when `None`) to the loop as
    /// the device's upload ([`PlanarSession::with_object`]); it is shown once the loop took it (at
    /// once for a stepped loop). `edited`: an edit of the running scene, which keeps the edit
    /// history and the material editor. An error names the scene (`label`) and says the
    /// running scene is unchanged.
    pub(super) fn swap(
        &mut self,
        label: &str,
        scene: Scene,
        object: Option<usize>,
        edited: bool,
    ) -> Result<(), String> {
        // An object the spatial hand feels leaves the planar device idle (it is planar).
        let felt_in_3d = object.filter(|&i| {
            scene
                .object(i)
                .is_some_and(super::surface_scene::can_be_felt)
        });
        let built = match (object, felt_in_3d) {
            (_, Some(_)) => PlanarSession::on(self.spec, scene.clone(), None),
            (Some(i), None) => PlanarSession::on(self.spec, scene.clone(), Some(i)),
            (None, None) => PlanarSession::new_on(self.spec, scene.clone()),
        };
        let session = built.map_err(|e| format!("{label}: {e}; the running scene is unchanged"))?;
        let view = SceneView::new(&self.scene_label(label, edited), &scene, session.object());
        let spatial = if view.is_planar() {
            None
        } else {
            let mut s = SpatialState::of_scene(
                label,
                &scene,
                felt_in_3d,
                self.is_threaded(),
                self.spatial_record(),
            )
            .map_err(|e| format!("{label}: {e:#}; the running scene is unchanged"))?;
            s.set_forces(self.forces_requested);
            Some(s)
        };
        let material = view
            .rendered
            .and_then(|i| scene.object(i))
            .map(|o| o.material().friction_material())
            .or_else(|| spatial.as_ref().and_then(SpatialState::material));
        if !self.command(LoopCommand::Swap(Box::new(session))) {
            return Err(format!(
                "{label}: the haptic loop did not take the scene: {}",
                self.refusal()
            ));
        }
        let pending = PendingScene {
            view,
            material,
            edited,
            spatial,
        };
        if self.backend.stepped().is_some() {
            // A stepped loop has already answered (in `command`).
            self.show_scene(pending);
        } else {
            self.pending = Some(pending);
        }
        Ok(())
    }

    /// The label a swapped scene is shown under: an edit keeps the running scene's (so the
    /// view is not refitted).
    fn scene_label(&self, label: &str, edited: bool) -> String {
        if edited {
            self.scene.label.clone()
        } else {
            label.to_owned()
        }
    }

    /// Saves the running scene (with the running material) to `path` as a `scene/1` file;
    /// an error names the file and the running scene is untouched.
    pub fn save_scene(&mut self, path: &Path) {
        // While a mesh is open the scene behind it is the idle placeholder, not what the
        // user sees: writing it would silently save the wrong thing.
        if self
            .spatial
            .as_ref()
            .is_some_and(SpatialState::is_opened_mesh)
        {
            self.files.saved = None;
            self.files.error = Some(format!(
                "{} is a mesh and scene/1 holds NURBS objects only: nothing was written to {}",
                self.scene.label,
                path.display()
            ));
            return;
        }
        let mut scene = self.scene.model.clone();
        if let (Some(i), Some(m)) = (self.felt_object(), self.running_material)
            && let Ok(m) = Material::from_friction(m)
        {
            scene = scene.with_material(i, m).unwrap_or(scene);
        }
        let text = scene.to_json_string();
        match std::fs::write(path, text) {
            Ok(()) => {
                self.files.saved = Some(format!("saved {}", path.display()));
                self.files.error = None;
            }
            Err(e) => {
                self.files.saved = None;
                self.files.error = Some(format!("cannot save {}: {e}", path.display()));
            }
        }
    }

    /// Enables or disables the forces.
    pub fn set_forces(&mut self, on: bool) {
        self.forces_requested = on;
        self.command(LoopCommand::Forces(on));
        if let Some(spatial) = &mut self.spatial {
            spatial.set_forces(on);
        }
    }

    /// Opens the OBJ file at `path` as the scene: one mesh, felt through the polygonal
    /// baseline with the default material (K = 1000 N/m), the planar device idle. An invalid
    /// file (the message names the file and line) or a mesh too big for a tick leaves the
    /// running scene.
    pub fn open_obj(&mut self, path: &Path) {
        let label = path.display().to_string();
        let opened = super::surface_scene::load_mesh(path).and_then(|obj| {
            let material = FrictionMaterial::default();
            SpatialState::of_mesh(
                &label,
                obj,
                material,
                self.is_threaded(),
                self.spatial_record(),
            )
        });
        let spatial = match opened {
            Ok(mut s) => {
                s.set_forces(self.forces_requested);
                s
            }
            Err(e) => {
                self.files.error = Some(format!("{e:#}; the running scene is unchanged"));
                return;
            }
        };
        // The planar device renders nothing while a mesh is open: a scene of surfaces only.
        let Some(idle_scene) = BUNDLED
            .iter()
            .find(|b| b.name == "thesis-3d")
            .and_then(|b| Scene::from_json_str(b.json).ok())
        else {
            return;
        };
        if let Ok(idle) = PlanarSession::on(self.spec, idle_scene.clone(), None) {
            self.command(LoopCommand::Swap(Box::new(idle)));
        }
        self.pending = None;
        self.scene = SceneView {
            model: idle_scene,
            label: label.clone(),
            objects: vec![ObjectView {
                name: spatial.view.rendered_name.clone().unwrap_or_default(),
                space: Space::Spatial,
                curves: Vec::new(),
                control_polygons: Vec::new(),
            }],
            rendered: None,
            bounds: {
                let (lo, hi) = spatial.view.bounds;
                (Vec2::new(lo.x, lo.y), Vec2::new(hi.x, hi.y))
            },
        };
        self.running_material = spatial.material();
        self.materials.edited = self.running_material.unwrap_or_default();
        self.spatial = Some(spatial);
        self.files.error = None;
        self.materials.error = None;
        self.telemetry.scene_opened();
        self.deform.scene_shown(&self.scene.model, None);
    }

    /// Clears the latched faults whose condition is gone.
    pub fn clear_faults(&mut self) {
        self.command(LoopCommand::ClearFaults);
    }

    /// Samples the UI channel dropped, commands dropped, and ticks the recorder dropped.
    pub fn dropped(&self) -> (u64, u64, u64) {
        let (samples, commands) = self.spatial.as_ref().map_or((0, 0), SpatialState::dropped);
        let (s, c, r) = self.backend.counters().map_or((0, 0, 0), |c| {
            (
                c.dropped_samples.load(Ordering::Relaxed),
                c.dropped_commands.load(Ordering::Relaxed),
                c.dropped_records.load(Ordering::Relaxed),
            )
        });
        (s + samples, c + commands, r)
    }

    /// Why the arm could not move on some tick, if that happened (stepped loops only).
    pub fn arm_error(&self) -> Option<String> {
        self.backend
            .stepped()
            .and_then(HapticLoop::last_error)
            .map(str::to_owned)
    }

    /// Whether the loop thread runs with real-time scheduling.
    pub fn loop_realtime(&self) -> bool {
        self.backend
            .counters()
            .is_some_and(|c| c.realtime.load(Ordering::Relaxed))
    }

    /// Whether the loop thread is running (always true for a stepped loop).
    pub fn loop_running(&self) -> bool {
        self.backend.is_running()
    }

    /// The recorder's input for the spatial hand (its ticks go to the 3-D run log).
    fn spatial_record(&self) -> Option<RecordTx> {
        self.record.as_ref().map(|r| r.for_space(Space::Spatial))
    }

    /// Stops the loop (joins its thread); the recorder's input closes with it.
    pub fn shutdown(&mut self) {
        self.backend.stop();
        self.record = None;
        self.spatial = None;
    }
}

/// How the app names a device.
pub fn describe(target: &Target) -> String {
    match target {
        Target::Serial(path) => format!("serial {path}"),
        Target::Tcp(address) => format!("tcp {address}"),
        Target::Hid => "USB HID".to_owned(),
        Target::Sim => "simulated device (protocol)".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every scene in `scenes/` is bundled (one click away in the app), and each loads and
    /// builds the device's session.
    #[test]
    fn every_scene_file_is_bundled_and_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .expect("scenes/")
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "json"))
            .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .collect();
        files.sort();
        let mut bundled: Vec<String> = BUNDLED.iter().map(|b| b.name.to_owned()).collect();
        bundled.sort();
        assert_eq!(files, bundled);
        for b in BUNDLED {
            let on_disk = std::fs::read_to_string(dir.join(format!("{}.json", b.name)))
                .expect("the scene file");
            assert_eq!(on_disk, b.json, "{} is embedded as it is on disk", b.name);
            let scene = Scene::from_json_str(b.json).unwrap_or_else(|e| panic!("{}: {e}", b.name));
            let session = PlanarSession::new(scene).unwrap_or_else(|e| panic!("{}: {e}", b.name));
            let planar = !matches!(b.name, "thesis-3d" | "torus");
            assert_eq!(session.object().is_some(), planar, "{}", b.name);
        }
    }
}
