//! The one window of every viewer mode: eframe's frame loop with the controls panel on the
//! left and the picture beside it. Each mode (a smoke asset, a scene file, a fog) is a
//! [`Room`] the shell calls on every pass.

use anyhow::{Result, anyhow};
use eframe::egui;
use std::sync::{Arc, Mutex};

/// How a window's run ends: `--play-for`'s measurement line, or why it could not go on.
pub type Outcome = Arc<Mutex<Option<Result<String, String>>>>;

/// A viewer mode, called by the shell on every pass of the frame loop.
pub trait Room {
    /// What the start of a pass learnt that the rest of it needs.
    type Pass;
    /// Before the panels: keys, the clock, the render of the current view.
    fn begin(&mut self, ctx: &egui::Context) -> Self::Pass;
    /// The controls panel.
    fn controls(&mut self, ui: &mut egui::Ui, pass: &Self::Pass);
    /// The picture.
    fn image(&mut self, ui: &mut egui::Ui);
    /// After the panels: `--play-for`'s end, and when the next pass comes.
    fn end(&mut self, ctx: &egui::Context, pass: Self::Pass);
}

/// The frame loop around a room.
struct Shell<R>(R);

impl<R: Room> eframe::App for Shell<R> {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let pass = self.0.begin(&ctx);
        egui::Panel::left("controls")
            .resizable(false)
            .default_size(290.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.0.controls(ui, &pass));
            });
        egui::CentralPanel::default().show(ui, |ui| self.0.image(ui));
        self.0.end(&ctx, pass);
    }
}

/// The error a room's constructor may fail with inside the window.
pub type MakeError = Box<dyn std::error::Error + Send + Sync>;

/// Opens a window titled `title` with room for a `size` picture beside the panel, runs the
/// room `make` builds until the window is closed (or `--play-for` has played), then prints
/// the measurement line the room left in `outcome`.
pub fn open<R: Room + 'static>(
    title: &str,
    size: (usize, usize),
    outcome: Outcome,
    make: impl FnOnce(&egui::Context) -> Result<R, MakeError> + 'static,
) -> Result<()> {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(title)
            // Room for the panel beside the picture, which is scaled to fit.
            .with_inner_size([
                (size.0 as f32 + 320.0).max(1000.0),
                (size.1 as f32 + 40.0).max(720.0),
            ]),
        ..Default::default()
    };
    eframe::run_native(
        title,
        options,
        Box::new(move |cc| Ok(Box::new(Shell(make(&cc.egui_ctx)?)))),
    )
    .map_err(|e| {
        let said = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        // Headless (no X or Wayland display): say how to play without a window.
        let hint = if said.contains("DISPLAY") || said.contains("WAYLAND") {
            "; without a display, `--play-for SECONDS --no-window` plays and prints the figures"
        } else {
            ""
        };
        anyhow!("cannot open the viewer window: {said}{hint}")
    })?;
    let taken = outcome.lock().map(|mut o| o.take()).unwrap_or(None);
    match taken {
        Some(Ok(line)) => {
            println!("{line}");
            Ok(())
        }
        Some(Err(e)) => Err(anyhow!(e)),
        None => Ok(()),
    }
}

/// Puts a picture (sRGB8 RGB, `[width, height]`) in `texture`, which is made on first use
/// under `name`: the one way every room shows what it rendered.
pub fn show_picture(
    ctx: &egui::Context,
    texture: &mut Option<egui::TextureHandle>,
    name: &str,
    size: [usize; 2],
    rgb: &[u8],
) {
    use egui::{ColorImage, TextureOptions};
    let image = ColorImage::from_rgb(size, rgb);
    match texture {
        Some(t) => t.set(image, TextureOptions::LINEAR),
        None => *texture = Some(ctx.load_texture(name, image, TextureOptions::LINEAR)),
    }
}

/// Paints `texture` as large as the space left allows, centred, its aspect kept, over an
/// area the user can drag: the area's response, and where the picture landed and at what
/// scale (`None` before the first picture).
pub fn fitted_picture(
    ui: &mut egui::Ui,
    texture: Option<&egui::TextureHandle>,
) -> (egui::Response, Option<(egui::Rect, f32)>) {
    let avail = ui.available_size();
    let (rect, response) = ui.allocate_exact_size(avail, egui::Sense::drag());
    let placed = texture.map(|tex| {
        let [w, h] = tex.size().map(|n| n as f32);
        let scale = (rect.width() / w).min(rect.height() / h);
        let shown = egui::Rect::from_center_size(rect.center(), egui::vec2(w, h) * scale);
        let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
        ui.painter()
            .image(tex.id(), shown, uv, egui::Color32::WHITE);
        (shown, scale)
    });
    (response, placed)
}
