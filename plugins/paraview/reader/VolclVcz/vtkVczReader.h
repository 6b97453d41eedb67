// vtkVczReader: a VTK/ParaView image reader of volcl .vcz files that decodes only the bricks of its piece.
#ifndef vtkVczReader_h
#define vtkVczReader_h

#include "VolclVczModule.h" // export macro
#include "vtkImageAlgorithm.h"

#include <memory> // std::unique_ptr
#include <string> // std::string

/// Reads a .vcz volume or series into vtkImageData (point scalars "values", the file's spacing and origin).
/// RequestInformation gives the whole extent at the selected level and the series' time steps without
/// decoding. RequestData serves piece requests: piece p of n is a slab along z made of whole brick layers,
/// so in a parallel run every rank decodes only the bricks of its own slab. Neighbouring slabs share one
/// sample plane (what seamless point-data rendering across ranks needs); under MPI the rank above sends
/// that plane instead of the rank below decoding another layer of bricks for it.
class VOLCLVCZ_EXPORT vtkVczReader : public vtkImageAlgorithm {
public:
    static vtkVczReader* New();
    vtkTypeMacro(vtkVczReader, vtkImageAlgorithm);
    void PrintSelf(ostream& os, vtkIndent indent) override;

    vtkSetStdStringFromCharMacro(FileName);
    vtkGetCharFromStdStringMacro(FileName);

    /// Resolution level: 0 full resolution, L a 2^L-downsampled approximation (no finer detail decoded).
    vtkSetClampMacro(Level, int, 0, 16);
    vtkGetMacro(Level, int);
    /// Levels the file holds, [0, levels], known after RequestInformation.
    vtkGetVector2Macro(LevelRange, int);

    /// Bricks this process decoded in its last RequestData (read from the decoder's own count).
    vtkGetMacro(DecodedBricks, int);
    /// JSON array of the last RequestData's figures per rank (piece, frame, level, z extent, bricks decoded,
    /// bricks in the file, read, decode and exchange milliseconds), gathered from all ranks under MPI.
    const char* GetDecodeReport() { return this->DecodeReport.c_str(); }

    /// True when the file opens as a .vcz (ParaView's reader selection).
    int CanReadFile(const char* name);

protected:
    vtkVczReader();
    ~vtkVczReader() override;

    int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
    int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
    vtkVczReader(const vtkVczReader&) = delete;
    void operator=(const vtkVczReader&) = delete;

    struct Internals;
    std::unique_ptr<Internals> Impl;
    std::string FileName;
    int Level = 0;
    int LevelRange[2] = {0, 0};
    int DecodedBricks = 0;
    std::string DecodeReport = "[]";
};

#endif
