//! A drawing backend that draws nothing and records where every text goes, with the box the
//! font's metrics give it: the tests check that no two labels of a chart overlap and that
//! every label lies inside the canvas.

use plotters::prelude::*;
use plotters_backend::{
    text_anchor::{HPos, VPos},
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};
use std::cell::RefCell;
use std::rc::Rc;

/// One drawn text and its box, (left, top, right, bottom) in pixels.
#[derive(Clone, Debug)]
pub(super) struct Placed {
    pub(super) text: String,
    pub(super) bbox: (i32, i32, i32, i32),
}

/// See the module docs.
pub(super) struct Audit {
    size: (u32, u32),
    /// Shared with the test: a drawing area keeps its backend to itself.
    pub(super) texts: Rc<RefCell<Vec<Placed>>>,
}

#[derive(Debug)]
pub(super) struct NoError;
impl std::fmt::Display for NoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("audit")
    }
}
impl std::error::Error for NoError {}

impl Audit {
    /// Pairs of non-empty texts whose boxes intersect (touching edges do not count).
    pub(super) fn overlaps(&self) -> Vec<(Placed, Placed)> {
        let all = self.texts.borrow();
        let t: Vec<&Placed> = all.iter().filter(|p| !p.text.trim().is_empty()).collect();
        let mut out = Vec::new();
        for (i, a) in t.iter().enumerate() {
            for b in &t[i + 1..] {
                let (a1, b1) = (a.bbox, b.bbox);
                if a1.0 < b1.2 && b1.0 < a1.2 && a1.1 < b1.3 && b1.1 < a1.3 {
                    out.push(((*a).clone(), (*b).clone()));
                }
            }
        }
        out
    }

    /// Texts reaching outside the canvas.
    pub(super) fn outside(&self) -> Vec<Placed> {
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        self.texts
            .borrow()
            .iter()
            .filter(|p| !p.text.trim().is_empty())
            .filter(|p| p.bbox.0 < 0 || p.bbox.1 < 0 || p.bbox.2 > w || p.bbox.3 > h)
            .cloned()
            .collect()
    }
}

impl DrawingBackend for Audit {
    type ErrorType = NoError;

    fn get_size(&self) -> (u32, u32) {
        self.size
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        _: BackendCoord,
        _: BackendColor,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        _: BackendCoord,
        _: BackendCoord,
        _: &S,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        _: BackendCoord,
        _: BackendCoord,
        _: &S,
        _: bool,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        _: BackendCoord,
        _: u32,
        _: &S,
        _: bool,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        _: I,
        _: &S,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        _: I,
        _: &S,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    /// The box the default `draw_text` would fill: the layout box moved by the anchor, then
    /// turned by the font's transform about `pos`.
    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<NoError>> {
        let ((x0, y0), (x1, y1)) = style
            .layout_box(text)
            .map_err(|_| DrawingErrorKind::DrawingError(NoError))?;
        let (w, h) = (x1 - x0, y1 - y0);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -w,
            HPos::Center => -w / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        let t = style.transform();
        let a = t.transform(dx, dy);
        let b = t.transform(dx + w, dy + h);
        self.texts.borrow_mut().push(Placed {
            text: text.to_string(),
            bbox: (
                pos.0 + a.0.min(b.0),
                pos.1 + a.1.min(b.1),
                pos.0 + a.0.max(b.0),
                pos.1 + a.1.max(b.1),
            ),
        });
        Ok(())
    }
}

/// Render `draw` on an audit canvas of `size` and fail with every overlap and overflow.
pub(super) fn check<F>(what: &str, size: (u32, u32), draw: F)
where
    F: FnOnce(&DrawingArea<Audit, plotters::coord::Shift>) -> Result<(), String>,
{
    super::font::register_font();
    let texts = Rc::new(RefCell::new(Vec::new()));
    let root = Audit {
        size,
        texts: texts.clone(),
    }
    .into_drawing_area();
    draw(&root).unwrap_or_else(|err| panic!("{what}: {err}"));
    let audit = Audit {
        size,
        texts: texts.clone(),
    };
    assert!(
        audit
            .texts
            .borrow()
            .iter()
            .any(|t| !t.text.trim().is_empty()),
        "{what}: no text drawn"
    );
    let over = audit.overlaps();
    assert!(over.is_empty(), "{what}: overlapping labels: {over:#?}");
    let out = audit.outside();
    assert!(
        out.is_empty(),
        "{what}: labels outside the canvas: {out:#?}"
    );
}
